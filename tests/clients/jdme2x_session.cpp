// SPDX-License-Identifier: GPL-3.0-or-later
// A session of libjdme2x (https://github.com/aschet/libjdme2x, BSL-1.0, an I++ DME 2.5 client
// library metron's authors did not write) against `metron serve`: its method builders and its
// wire format, its Asio client, its response parser. Built and run by run_jdme2x_session.sh
// (docs/ipp-dme.md, "Third-party clients"); not part of the CI, the library is not vendored.
//
// Each step is sent, then the session waits for that tag's '%' or error; the step says what
// it expects. Exit status: the number of steps that did not answer as expected.
#include <jdme2x/Client/BasicClient.h>
#include <jdme2x/Client/CartCMMMethodBuilder.h>
#include <jdme2x/Client/DMEMethodBuilder.h>
#include <jdme2x/Client/ServerMethodBuilder.h>
#include <jdme2x/Types/Command.h>
#include <jdme2x/Types/Property.h>
#include <jdme2x/Types/Response.h>

#include <chrono>
#include <condition_variable>
#include <cstdlib>
#include <iostream>
#include <mutex>
#include <sstream>
#include <string>
#include <vector>

using namespace jdme2x;

namespace {

struct Step {
  Method method;
  bool expect_error = false;
  std::string expect_data;  ///< a substring of the data lines, or empty
};

Method point_method(const char* name, double x, double y, double z, bool with_ijk = false) {
  Method m(name);
  m.with(Property("X").with(Number(x))).with(Property("Y").with(Number(y))).with(Property("Z").with(Number(z)));
  if (with_ijk) m.with(Property("IJK").with(Number(0.0)).with(Number(0.0)).with(Number(1.0)));
  return m;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string host = argc > 1 ? argv[1] : "127.0.0.1";
  const unsigned short port = static_cast<unsigned short>(argc > 2 ? std::atoi(argv[2]) : 1294);

  // The default world's block stands at machine (300, 200, 0); its top face is z = 40.
  std::vector<Step> steps = {
      {ServerMethodBuilder::buildStartSession()},
      {DMEMethodBuilder::buildGetDMEVersion(), false, "DMEVersion"},
      {DMEMethodBuilder::buildGetMachineClass(), false, "CartCMM"},
      {DMEMethodBuilder::buildHome()},
      {DMEMethodBuilder::buildIsHomed(), false, "IsHomed(1)"},
      {Method("ChangeTool").with(String("Probe1"))},
      {point_method("GoTo", 310, 210, 100)},
      {point_method("PtMeas", 310, 210, 41, true), false, "Z(40.9"},
      {Method("Get").with(Property("X")).with(Property("Y")).with(Property("Z")), false, "X("},
      {CartCMMMethodBuilder::buildSetCoordSystem(CoordSystem::MachineCsy)},
      {CartCMMMethodBuilder::buildGetCoordSystem(), false, "MachineCsy"},
      {CartCMMMethodBuilder::buildSaveNamedCsyTransformation(String("Fixture"), 300, 200, 0, 0, 90, 0)},
      {CartCMMMethodBuilder::buildEnumCoordSystems(), false, "\"Fixture\""},
      {CartCMMMethodBuilder::buildGetNamedCsyTransformation(String("Fixture")), false, "300, 200, 0, 0, 90, 0"},
      {CartCMMMethodBuilder::buildDeleteCoordSystem(String("Fixture"))},
      {CartCMMMethodBuilder::buildGetNamedCsyTransformation(String("Fixture")), true},
      {ServerMethodBuilder::buildClearAllErrors()},
      {ServerMethodBuilder::buildGetErrorInfo(1003), false, "No touch"},
      {point_method("PtMeas", 340, 250, 41, true), true},  // BORE1 is there: no contact, 1003
      {ServerMethodBuilder::buildClearAllErrors()},
      // The Part object of I++ DME 1.5 and the measured normal IJKAct, through the library's
      // property builders.
      {ServerMethodBuilder::buildSetProp({Property(Name("Part.Temperature")).with(Number(21.5))})},
      {ServerMethodBuilder::buildGetProp({Name("Part.Temperature")}), false, "Part.Temperature(21.5)"},
      {Method("OnPtMeasReport").with(Property("X")).with(Property("Y")).with(Property("Z")).with(Property("IJKAct"))},
      {point_method("GoTo", 340, 250, 100)},  // out of BORE1, where the missed point left the probe
      {point_method("GoTo", 310, 210, 100)},
      // The answer carries IJKAct(0, 0, 1) (tests/machine IppSession.MeasuredNormalIsAReportItem);
      // the library's response parser keeps one number per property and drops it (at commit
      // 1c3dcc5 its NextPropertyValueState takes no second number), so the step checks the rest.
      {point_method("PtMeas", 310, 210, 41, true), false, "Z(40.9"},
      {ServerMethodBuilder::buildEndSession()},
  };

  std::mutex mutex;
  std::condition_variable changed;
  std::vector<Response> responses;
  BasicClient client(host, port);
  client.setResponseHandler([&](Response&& r) {
    std::lock_guard lock(mutex);
    responses.push_back(std::move(r));
    changed.notify_all();
  });

  int failures = 0;
  for (std::size_t i = 0; i < steps.size(); ++i) {
    const Tag tag(static_cast<unsigned>(i + 1), TagType::Command);
    std::cout << ">> " << Command::toString(tag, steps[i].method);
    client.send(tag, steps[i].method);
    std::unique_lock lock(mutex);
    bool finished = false, error = false;
    std::string data;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    while (!finished) {
      for (auto& r : responses) {
        if (r.toString().rfind(Response::toString(tag, Done()).substr(0, 5), 0) != 0) continue;
        if (r.holdsDone()) finished = true;
        if (r.holdsError()) error = true;
        if (r.holdsData()) data += r.toString();
      }
      if (finished) break;
      if (changed.wait_until(lock, deadline) == std::cv_status::timeout) break;
    }
    responses.clear();
    const bool ok = finished && error == steps[i].expect_error &&
                    (steps[i].expect_data.empty() || data.find(steps[i].expect_data) != std::string::npos);
    if (!ok) {
      ++failures;
      std::cout << "   step " << i + 1 << " did not answer as expected" << (finished ? "" : " (no '%' within 30 s)")
                << (error ? " (error)" : "") << (data.empty() ? "" : ": " + data) << "\n";
    }
  }
  std::cout << steps.size() - static_cast<std::size_t>(failures) << " of " << steps.size() << " steps as expected\n";
  return failures;
}
