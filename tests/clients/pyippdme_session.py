#!/usr/bin/python3
"""Drive `metron serve` with a third-party I++ DME client, pyippdme (github.com/aschet/pyippdme,
MPL-2.0; not part of metron and not packaged by Debian: install it, or point --src at its src/).

Usage: python3 tests/clients/pyippdme_session.py [--metron PATH] [--world FILE] [--src DIR] [--log FILE]
(pyippdme needs lark, numpy and defusedxml: python3-lark python3-numpy python3-defusedxml.)
See docs/ipp-dme.md, "A third-party client".

Runs three sessions against fresh `metron serve --port 0` processes over loopback:
  A  typed API (pyippdme.IppDmeMachine), simulated time
  B  low-level API (pyippdme.IppDmeClient) as in pyippdme's docs/index.md quickstart,
     plus the E-tagged commands sent by hand
  C  typed API again against `metron serve --realtime`, with AbortE during a long GoTo
Each step states what is expected: OK (client accepts the answer), or REJECT (a known
incompatibility: the client rejects metron's answer, or metron rejects the client's line).
A step whose outcome differs from its expectation is a FAIL; the exit status is the number
of FAILs (0 = everything behaved as documented). Wire transcripts go to transcript-*.txt.
"""

from __future__ import annotations

import argparse
import asyncio
import os
import re
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
ap = argparse.ArgumentParser()
ap.add_argument("--metron", default=os.path.join(ROOT, "build", "cli", "metron"))
ap.add_argument("--world", default=os.path.join(ROOT, "programs", "worlds", "perfect.json"))
ap.add_argument("--src", default=os.environ.get("PYIPPDME_SRC", ""), help="pyippdme's src/ (default: installed)")
ap.add_argument("--log", default="pyippdme_server.log")
ap.add_argument("--out", default=".", help="folder for the wire transcripts")
args = ap.parse_args()
if args.src:
    sys.path.insert(0, args.src)

from pyippdme import CommandName, IppDmeClient, IppDmeMachine  # noqa: E402
from pyippdme.client import builders  # noqa: E402
from pyippdme.exceptions import IppDmeServerError  # noqa: E402
from pyippdme.protocol.ast import EventTag, Items, NumericData, StringValue  # noqa: E402

RESULTS: list[tuple[str, str, str, str]] = []  # (session, step, verdict, detail)
TIMEOUT = 20.0


def start_server(realtime: bool) -> tuple[subprocess.Popen, int]:
    cmd = [args.metron, "serve", "--port", "0", "--world", args.world, "--log", args.log]
    if realtime:
        cmd.append("--realtime")
    print("$ " + " ".join(cmd))
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    first = proc.stdout.readline()
    print("  server: " + first.strip())
    m = re.search(r":(\d+)\b", first)
    if not m:
        proc.kill()
        raise SystemExit(f"could not read the port from {first!r}")
    return proc, int(m.group(1))


def stop_server(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(5)
        except subprocess.TimeoutExpired:
            proc.kill()
    print(f"  server exit code: {proc.returncode}")


class Transcript:
    def __init__(self, name: str) -> None:
        self.name = name
        self.lines: list[str] = []

    def sent(self, text: str) -> None:
        self.lines.append(f"C> {text}")

    def received(self, text: str) -> None:
        self.lines.append(f"S< {text}")

    def save(self) -> None:
        path = os.path.join(args.out, f"transcript-{self.name}.txt")
        with open(path, "w") as f:
            f.write("\n".join(self.lines) + "\n")
        print(f"  wire transcript: {path} ({len(self.lines)} lines)")


async def step(session: str, name: str, awaitable, expect="ok", check=None):
    """Run one step. expect: "ok" or ("reject", ExceptionClass, substring-of-message)."""
    try:
        value = await asyncio.wait_for(awaitable, TIMEOUT)
    except Exception as exc:  # noqa: BLE001
        text = f"{type(exc).__name__}: {exc}"
        if expect != "ok" and isinstance(exc, expect[1]) and expect[2] in str(exc):
            verdict = "REJECT (known)"
        else:
            verdict = "FAIL"
        RESULTS.append((session, name, verdict, text))
        print(f"  [{verdict}] {name}: {text}")
        return None
    detail = repr(value)
    verdict = "OK"
    if expect != "ok":
        verdict, detail = "FAIL", f"expected a rejection, got {detail}"
    elif check is not None:
        problem = check(value)
        if problem:
            verdict, detail = "FAIL", f"{detail} -- {problem}"
    RESULTS.append((session, name, verdict, detail))
    print(f"  [{verdict}] {name}: {detail}")
    return value


def near(expected: float, tol: float, key=None):
    def check(value):
        v = value if key is None else key(value)
        return None if abs(v - expected) <= tol else f"{v} not within {tol} of {expected}"

    return check


def equals(expected):
    return lambda value: None if value == expected else f"expected {expected!r}"


async def collect(stream):
    return [p async for p in stream]


async def session_a(port: int) -> None:
    print("\n== A: typed client pyippdme.IppDmeMachine, simulated time ==")
    tr = Transcript("A")
    m = await IppDmeMachine.connect("127.0.0.1", port, on_line_sent=tr.sent, on_line_received=tr.received)
    S = "A"
    await step(S, "StartSession", m.start_session())
    await step(S, "GetDMEVersion", m.dme.get_dme_version(), check=equals("1.4"))
    await step(S, "GetMachineClass (typed)", m.dme.get_machine_class(),
               expect=("reject", TypeError, "Expected a StringValue response, got Items"))
    await step(S, "IsHomed before Home", m.dme.is_homed(), check=equals(False))
    await step(S, "Home", m.dme.home())
    await step(S, "IsHomed after Home", m.dme.is_homed(), check=equals(True))
    await step(S, "EnumTools (typed)", m.tool_changer.enum_tools(),
               expect=("reject", TypeError, "Expected a NameValue response, got StringValue"))
    await step(S, 'ChangeTool("Probe1")', m.tool_changer.change_tool("Probe1"))
    await step(S, "GetProp Tool.Name", m.tool.get_name(), check=equals("Probe1"))
    await step(S, "GetProp Tool.AvrRadius", m.server.get_prop("Tool.AvrRadius"), check=near(1.0, 1e-9))
    await step(S, "GetProp Tool.Alignment", m.tool.get_alignment(), check=equals((0.0, 0.0, 1.0)))
    await step(S, "GetProp Tool.PtMeasPar.Approach Min/Max/Def/Act",
               m.tool.get_parameter("PtMeasPar", "Approach"))
    await step(S, "GetProp Tool.GoToPar.Speed + Tool.PtMeasPar.Search",
               m.server.get_props("Tool.GoToPar.Speed", "Tool.PtMeasPar.Search"))
    await step(S, "SetProp Tool.PtMeasPar.Search(4)", m.tool.set_parameter("PtMeasPar", "Search", 4))
    await step(S, "GetProp Tool.PtMeasPar.Search after SetProp",
               m.server.get_prop("Tool.PtMeasPar.Search"), check=near(4.0, 1e-9))
    await step(S, "EnumProp Tool.PtMeasPar", m.server.enum_prop("Tool.PtMeasPar"))
    await step(S, "GetProp Tool.Id (typed, expects Annex G XML)", m.tool.get_id(),
               expect=("reject", TypeError, "did not return an XML payload"))
    await step(S, "GoTo(350,250,60)", m.cart_cmm.go_to(350, 250, 60))
    await step(S, "Get(X(),Y(),Z())", m.cart_cmm.get_position(), check=equals((350.0, 250.0, 60.0)))
    await step(S, "OnPtMeasReport(X,Y,Z,IJK,ER)", m.cart_cmm.on_pt_meas_report("X", "Y", "Z", "IJK", "ER"))
    await step(S, "PtMeas(X(350),Y(250),Z(41),IJK(0,0,1)) [rim of BORE1]",
               m.cart_cmm.pt_meas(350, 250, 41, ijk=(0, 0, 1)), check=near(41.0, 0.001, lambda r: r.number("Z")))
    await step(S, "GoTo(380,250,60)", m.cart_cmm.go_to(380, 250, 60))
    r = await step(S, "PtMeas(X(380),Y(250),Z(41),IJK(0,0,1)) [plain top face]",
                   m.cart_cmm.pt_meas(380, 250, 41, ijk=(0, 0, 1)),
                   check=near(41.0, 0.001, lambda r: r.number("Z")))
    if r is not None:
        await step(S, "  PtMeas answer: X, Y, IJK, ER", asyncio.sleep(0, (r.number("X"), r.number("Y"), r.vector("IJK"), r.number("ER"))),
                   check=equals((380.0, 250.0, (0.0, 0.0, 1.0), 1.0)))
    daemon = await step(S, "OnMoveReportE(Time(0.1),Dis(1),X(),Y(),Z()) via mover.on_move_report(prioritized=True)",
                        m.mover.on_move_report(0.1, 1, "X", "Y", "Z", prioritized=True))
    await step(S, "GoTo(390,250,60) with the daemon running", m.cart_cmm.go_to(390, 250, 60))
    if daemon is not None:
        async def first_event():
            async for payload in daemon.events():
                return payload
        await step(S, "daemon report received through Transaction.events()", first_event(),
                   check=lambda p: None if isinstance(p, Items) and p.to_wire().startswith("X(") and "Y(250)" in p.to_wire() else "unexpected report")
        await step(S, "StopDaemon(E-tag)", m.server.stop_daemon(daemon.tag))
    pts = await step(S, "ScanOnLine(310,206,41 -> 450,206,41, IJK 0,0,1, StepW 2) via scanning.scan_on_line",
                     collect(m.scanning.scan_on_line((310, 206, 41), (450, 206, 41), (0, 0, 1), 2.0)),
                     check=lambda pts: None if len(pts) >= 60 and all(abs(p[2] - 41) < 0.01 for p in pts) else "points not on z=41 or too few")
    if pts:
        print(f"      {len(pts)} points, first {pts[0]}, last {pts[-1]}")
    await step(S, "ScanOnLine with reporting(X,Y,Z,IJK)",
               collect(m.scanning.reporting("X", "Y", "Z", "IJK").scan_on_line((310, 206, 41), (450, 206, 41), (0, 0, 1), 10.0)),
               check=lambda pts: None if pts and all(abs(p.vector("IJK")[2] - 1.0) < 1e-3 and abs(p.number("Z") - 41) < 0.01 for p in pts) else "bad IJK/Z")
    await step(S, "GetCoordSystem (typed)", m.cart_cmm.get_coord_system(),
               expect=("reject", TypeError, "Expected a NameValue response, got Items"))
    await step(S, "GetCsyTransformation(PartCsy) (typed)", m.cart_cmm.get_csy_transformation("PartCsy"),
               expect=("reject", ValueError, "too many values to unpack"))
    await step(S, "GetErrStatusE via server.get_err_status() (sent with a numeric tag)",
               m.server.get_err_status(), expect=("reject", IppDmeServerError, "0001"))
    await step(S, "GetXtdErrStatus (no error)", m.server.get_xtd_err_status(),
               check=equals({"IsHomed": 1.0, "IsUserEnabled": 0.0}))
    await step(S, "PtMeas in the air: PtMeas(X(380),Y(250),Z(80),IJK(0,0,1)) -> 1003",
               m.cart_cmm.pt_meas(380, 250, 80, ijk=(0, 0, 1)), expect=("reject", IppDmeServerError, "1003"))
    await step(S, "GoTo outside travel: GoTo(X(99999),Y(250),Z(60)) -> 1008",
               m.cart_cmm.go_to(99999, 250, 60), expect=("reject", IppDmeServerError, "1008"))
    await step(S, "GoTo after a class-3 error -> 0514", m.cart_cmm.go_to(380, 250, 60),
               expect=("reject", IppDmeServerError, "0514"))
    await step(S, "GetXtdErrStatus with an active error (typed)", m.server.get_xtd_err_status(),
               expect=("reject", TypeError, "Expected numbers or one string for 'Error'"))
    await step(S, "GetErrorInfo(1008)", m.server.get_error_info(1008),
               check=equals("Target position out of machine volume"))
    await step(S, "ClearAllErrors", m.server.clear_all_errors())
    await step(S, "GoTo after ClearAllErrors", m.cart_cmm.go_to(380, 250, 60))
    await step(S, "IsUserEnabled", m.mover.is_user_enabled(), check=equals(False))
    await step(S, "EndSession", m.end_session())
    await step(S, "close", m.close())
    tr.save()


async def session_b(port: int) -> None:
    print("\n== B: low-level client pyippdme.IppDmeClient (docs quickstart) + E-tagged commands by hand ==")
    tr = Transcript("B")
    S = "B"
    c = await IppDmeClient.connect("127.0.0.1", port, on_line_sent=tr.sent, on_line_received=tr.received)
    await step(S, "start_session()", c.start_session())
    (version,) = await c.call(CommandName.GET_DME_VERSION)
    await step(S, "call(GET_DME_VERSION)", asyncio.sleep(0, version.to_wire()), check=equals('DMEVersion("1.4")'))
    await step(S, "call(GET_MACHINE_CLASS) raw", c.call(CommandName.GET_MACHINE_CLASS),
               check=lambda d: None if d[0].to_wire() == 'GetMachineClass("CartCMM")' else "unexpected")
    await step(S, "call(GO_TO, *builders.go_to(x=10)) before Home -> 0507", c.call(CommandName.GO_TO, *builders.go_to(x=10)),
               expect=("reject", IppDmeServerError, "0507"))
    await step(S, "clear_all_errors()", c.clear_all_errors())
    await step(S, "call(HOME)", c.call(CommandName.HOME))
    await step(S, "call(ENUM_TOOLS) raw", c.call(CommandName.ENUM_TOOLS),
               check=lambda d: None if all(isinstance(x, StringValue) for x in d) and [x.value.value for x in d] == ["NoTool", "BaseTool", "RefTool", "Probe1"] else "unexpected")
    await step(S, 'call(CHANGE_TOOL, "Probe1")', c.call(CommandName.CHANGE_TOOL, *[__import__("pyippdme.protocol.ast", fromlist=["String"]).String("Probe1")]))
    await step(S, "get_prop(Tool.Name, Tool.Id, Tool.AvrRadius)", c.get_prop("Tool.Name", "Tool.Id", "Tool.AvrRadius"),
               check=lambda d: None if d[0].to_wire() == 'Tool.Name("Probe1"),Tool.Id("4"),Tool.AvrRadius(1)' else "unexpected")
    await step(S, "call(GO_TO, *builders.go_to(x=380, y=250, z=60))", c.call(CommandName.GO_TO, *builders.go_to(x=380, y=250, z=60)))

    async def e_command(name, *a):
        txn = c.send(name, *a, tag=c.allocate_event_tag())
        await c._transport.drain()
        return await txn.wait_complete()

    await step(S, "GetErrStatusE() sent with an E tag via send(tag=allocate_event_tag())", e_command("GetErrStatusE"),
               check=lambda d: None if d and d[0].to_wire() == "ErrStatus(0)" else "unexpected")
    await step(S, "GetPropE(Tool.Name()) with an E tag", e_command("GetPropE", *builders.get_prop("Tool.Name")))
    await step(S, "AbortE() with an E tag (nothing moving)", e_command("AbortE"))
    await step(S, "ScanOnLine raw via call_streaming", collect(c.call_streaming(
        CommandName.SCAN_ON_LINE, *builders.positional((310, 206, 41), (450, 206, 41), (0, 0, 1), 20.0))),
        check=lambda d: None if len(d) == 1 and isinstance(d[0], NumericData) else "expected one data line")
    await step(S, "end_session()", c.end_session())
    await step(S, "close()", c.close())
    tr.save()


async def session_c(port: int) -> None:
    global TIMEOUT
    TIMEOUT = 120.0
    print("\n== C: typed client against metron serve --realtime, AbortE during a GoTo ==")
    tr = Transcript("C")
    S = "C"
    m = await IppDmeMachine.connect("127.0.0.1", port, on_line_sent=tr.sent, on_line_received=tr.received)
    await step(S, "StartSession", m.start_session())
    t0 = time.monotonic()
    await step(S, "Home", m.dme.home())
    print(f"      Home took {time.monotonic() - t0:.2f} s wall clock")
    await step(S, 'ChangeTool("Probe1")', m.tool_changer.change_tool("Probe1"))
    t0 = time.monotonic()
    await step(S, "GoTo(380,250,60)", m.cart_cmm.go_to(380, 250, 60))
    print(f"      GoTo took {time.monotonic() - t0:.2f} s wall clock")
    await step(S, "OnPtMeasReport(X,Y,Z)", m.cart_cmm.on_pt_meas_report("X", "Y", "Z"))
    t0 = time.monotonic()
    await step(S, "PtMeas(X(380),Y(250),Z(41),IJK(0,0,1))", m.cart_cmm.pt_meas(380, 250, 41, ijk=(0, 0, 1)),
               check=near(41.0, 0.001, lambda r: r.number("Z")))
    print(f"      PtMeas took {time.monotonic() - t0:.2f} s wall clock")
    t0 = time.monotonic()
    pts = await step(S, "ScanOnLine(310,206,41 -> 340,206,41, StepW 5)",
                     collect(m.scanning.scan_on_line((310, 206, 41), (340, 206, 41), (0, 0, 1), 5.0)),
                     check=lambda pts: None if pts and all(abs(p[2] - 41) < 0.01 for p in pts) else "bad")
    print(f"      ScanOnLine took {time.monotonic() - t0:.2f} s wall clock")
    # A long move, then AbortE through the typed API (numeric tag) ...
    await step(S, "GoTo(380,250,200) (short)", m.cart_cmm.go_to(380, 250, 200))
    move = m.cart_cmm.go_to(1000, 700, 200)
    await step(S, "long GoTo(1000,700,200) acknowledged", move.acknowledged())
    await step(S, "AbortE via server.abort_e() (numeric tag) during the move",
               m.server.abort_e(), expect=("reject", IppDmeServerError, "0001"))
    await step(S, "the long GoTo completes normally", move)
    # ... and AbortE with an E tag by hand.
    move = m.cart_cmm.go_to(0, 0, 200)
    await step(S, "long GoTo(0,0,200) acknowledged", move.acknowledged())
    await asyncio.sleep(0.3)
    txn = m.client.send("AbortE", tag=m.client.allocate_event_tag())
    await step(S, "AbortE() with an E tag during the move", txn.wait_complete())
    await step(S, "the aborted GoTo raises 0006", move, expect=("reject", IppDmeServerError, "0006"))
    pos = await step(S, "position after the abort (somewhere on the way)", m.cart_cmm.get_position())
    await step(S, "ClearAllErrors", m.server.clear_all_errors())
    await step(S, "EndSession", m.end_session())
    await step(S, "close", m.close())
    tr.save()


def main() -> int:
    if os.path.exists(args.log):
        os.remove(args.log)
    for name, realtime, fn in (("A", False, session_a), ("B", False, session_b), ("C", True, session_c)):
        proc, port = start_server(realtime)
        try:
            asyncio.run(fn(port))
        except Exception as exc:  # noqa: BLE001
            RESULTS.append((name, "session", "FAIL", f"{type(exc).__name__}: {exc}"))
            print(f"  [FAIL] session {name} aborted: {type(exc).__name__}: {exc}")
        finally:
            stop_server(proc)
    print("\n== summary ==")
    counts: dict[str, int] = {}
    for s, name, verdict, detail in RESULTS:
        counts[verdict] = counts.get(verdict, 0) + 1
    for s, name, verdict, detail in RESULTS:
        if verdict != "OK":
            print(f"  {s} [{verdict}] {name}: {detail}")
    print("  " + ", ".join(f"{k}: {v}" for k, v in sorted(counts.items())))
    print(f"  server log: {args.log}")
    fails = counts.get("FAIL", 0)
    print("RESULT: " + ("PASS (all steps behaved as expected)" if fails == 0 else f"{fails} FAIL(s)"))
    return min(fails, 100)


if __name__ == "__main__":
    sys.exit(main())
