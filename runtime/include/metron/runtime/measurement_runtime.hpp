// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "metron/machine/machine.hpp"
#include "metron/runtime/alignment.hpp"
#include "metron/runtime/alignment_ops.hpp"
#include "metron/runtime/characterisation.hpp"
#include "metron/runtime/error_space/calibrate_command.hpp"
#include "metron/runtime/feature.hpp"
#include "metron/runtime/requests.hpp"
#include "metron/runtime/run_record.hpp"
#include "metron/runtime/runtime_error.hpp"
#include "metron/runtime/scan.hpp"
#include "metron/runtime/tolerance.hpp"
#include "metron/stdlib/file_access.hpp"
#include "metron/stdlib/fitting/best_fit_frame.hpp"
#include "metron/stdlib/source.hpp"

namespace metron::machine::wavefront {
class WavefrontMachine;
}

namespace metron::runtime {

struct BlockPlan;
struct BlockPlanContext;

/// The measurement runtime: feature store, alignments, tolerances, the scheduler that turns
/// measurement blocks into machine commands, and the outputs. The interpreter calls it.
/// Builds the wavefront station of a world file (kind "wavefront") for CALIBRATE WAVEFRONT. The
/// composition root provides it (the simulation is not the runtime's to build, ARCHITECTURE.md);
/// the error names the file.
using WavefrontStationFactory =
    std::function<tl::expected<std::unique_ptr<machine::wavefront::WavefrontMachine>, std::string>(
        const std::string& world_path)>;

/// The results file of CALIBRATE WAVEFRONT in the run's output directory: wavefront-calibration.json
/// for the whole procedure, wavefront-calibration-STEP.json for one step.
std::string wavefront_result_file_name(const std::string& step);

class MeasurementRuntime {
 public:
  MeasurementRuntime(machine::Machine& machine, const SourceManager& sources, RunRecord& record);

  /// Called for every OUTPUT result, text and fault as it happens (the live report).
  void on_event(std::function<void(const RunEvent&)> callback) { m_on_event = std::move(callback); }
  /// Where DMIS output files (DEVICE/STOR) are written: their base name in this directory.
  void set_output_directory(std::string dir) { m_output_dir = std::move(dir); }
  [[nodiscard]] const std::string& output_directory() const { return m_output_dir; }
  /// How many events the run has reported so far (the output limit, docs/limits.md).
  [[nodiscard]] std::size_t record_event_count() const { return m_record.events.size(); }
  /// What the program may read and write (docs/security.md): CHARACTERISE 'file' and
  /// CHARACTERISATION 'file' are checked against it; DMIS output files are written in the
  /// output directory only.
  void set_file_policy(FileAccessPolicy policy) { m_policy = std::move(policy); }
  /// Output files that could not be written completely (finish() and CLOSE/DID); the run
  /// reports them and exits non-zero.
  [[nodiscard]] const std::vector<std::string>& output_errors() const { return m_output_errors; }

  // Features and tolerances.
  Result<void> define_feature(const std::string& label, const Geometry& nominal_current, Span span);
  /// FA(l)=FEAT/...: a stated actual (current frame), as DMIS output files report one; it becomes
  /// the feature's actual, and its nominal too when the feature has none.
  Result<void> define_reported_actual(const std::string& label, const Geometry& actual_current, Span span);
  Result<void> define_tolerance(ToleranceSpec spec);
  [[nodiscard]] const Feature* find_feature(const std::string& label) const;
  [[nodiscard]] const ToleranceSpec* find_tolerance(const std::string& label) const;
  /// EXIST(prefix(label)): F, D, T, S, DID defined; FA measured or constructed; DA saved or
  /// defined; TA evaluated; SA a sensor defined or already taken from the probe library. False
  /// for other prefixes.
  [[nodiscard]] bool label_exists(const std::string& prefix, const std::string& label) const;
  [[nodiscard]] const std::map<std::string, Feature>& features() const { return m_features; }
  /// A feature's nominal or actual in the current frame (for OBTAIN, the debugger).
  Result<Geometry> feature_geometry(const FeatureRef& ref, Span span) const;

  // Sensors, settings and motion.
  Result<void> define_sensor(const SensorDefinition& sensor, Span span);
  /// SNSLCT: selects the sensor, qualifying it at its first use; `requalify` (CALIB/SENS)
  /// qualifies it again at the current measuring feed.
  Result<void> select_sensor(const std::string& label, Span span, bool requalify = false);
  /// GEOALG/type,algorithm: how the features of `type` measured (or fitted by CONST BF) from now
  /// on are sized and located: least squares, maximum inscribed, minimum circumscribed, minimum
  /// zone. Circle (and arc), sphere, cylinder: all four; plane and line: least squares or
  /// minimum zone.
  enum class FitAlgorithm { LeastSquares, MaximumInscribed, MinimumCircumscribed, MinimumZone };
  void set_fit_algorithm(FeatureType type, FitAlgorithm algorithm) { m_fit_algorithms[type] = algorithm; }
  /// A sensor the program did not define, from the machine's probe library (a 4 mm default
  /// tip, with a warning, for a name the library does not hold).
  Result<void> select_library_sensor(const std::string& label, Span span);
  /// A positioned run-time warning in the record (the interpreter's PROMPT default, ...).
  void warning(Span span, const std::string& message) { warn(span, message); }
  ProbeSettings& probe_settings() { return m_probe; }
  /// A machine characterisation (docs/touch-trigger.md): PTMEAS then uses its strategy, feeds
  /// and standoff; SNSET/APPRCH and FEDRAT/MESVEL stay explicit overrides, and a measuring feed
  /// above its maximum protected feed is refused.
  void set_characterisation(std::optional<MachineCharacterisation> characterisation) {
    m_characterisation = std::move(characterisation);
  }
  [[nodiscard]] const MachineCharacterisation* characterisation() const {
    return m_characterisation ? &*m_characterisation : nullptr;
  }
  /// A conventional touch cycle instead of the characterised one (`run --touch-baseline`).
  void set_touch_baseline(std::optional<TouchBaseline> baseline) { m_touch_baseline = baseline; }
  /// Characterises the machine now (CALL/EXTERN,SYS,'CHARACTERISE [file]'): the routines of
  /// characterisation.hpp with default settings; the result is used from here on and written to
  /// `path` (relative to the output directory) when given; a report goes to the live events.
  Result<void> characterise_machine(const std::optional<std::string>& path, Span span);
  /// Loads a characterisation file and uses it from here on (CALL/EXTERN,SYS,'CHARACTERISATION file').
  Result<void> use_characterisation(const std::string& path, Span span);
  /// Loads an error-space file and compensates by it from here on (CALL/EXTERN,SYS,'COMPENSATION
  /// file', docs/error-space.md): the backend must be a machine::CompensatedMachine, as the
  /// composition root builds it.
  Result<void> use_compensation(const std::string& path, Span span);
  /// The wavefront station's geometry calibration (CALL/EXTERN,SYS,'CALIBRATE WAVEFRONT world [step]';
  /// runtime/src/wavefront/system_command.cpp, docs/wavefront.md): the SEEDS.md 5 procedure on the
  /// station the factory builds for `world_path`, its JSON written into the output directory as
  /// wavefront_result_file_name(step), a summary to the live events.
  Result<void> calibrate_wavefront(const std::string& world_path, const std::string& step, Span span);
  /// Where CALIBRATE WAVEFRONT gets its station (none: the command fails with a message).
  void set_wavefront_stations(WavefrontStationFactory factory) { m_wavefront_stations = std::move(factory); }
  /// The error-space calibration of the run's machine (CALL/EXTERN,SYS,'CALIBRATE ERROR-SPACE ...';
  /// runtime/src/error_space/calibrate_command.cpp, docs/error-space.md): the rig the composition
  /// root provides measures, the map and its report go into the output directory, and the
  /// controller compensates by the map from here on.
  Result<void> calibrate_error_space(const ErrorSpaceRequest& request, Span span);
  /// Where CALIBRATE ERROR-SPACE gets its rig (none: the command fails with a message).
  void set_error_space_rig(ErrorSpaceRig rig) { m_error_space_rig = std::move(rig); }
  /// Checks a probing feed against the characterisation's maximum protected feed.
  Result<void> check_probing_feed(double measuring_mm_s, Span span) const;
  Result<void> set_feeds(std::optional<double> positioning_mm_s, std::optional<double> measuring_mm_s, Span span);
  /// FEDRAT/POSVEL|MESVEL,DEFALT: the machine's own positioning or measuring feed, as it was
  /// before the program set one.
  Result<void> restore_default_feed(bool positioning, Span span);
  /// ACLRAT/...,DEFALT: the machine's own acceleration again.
  Result<void> restore_default_acceleration(Span span);
  Result<void> set_acceleration(double acceleration_mm_s2, Span span);
  void set_mode(Mode mode) { m_mode = mode; }
  /// UNITS and DECPL: what OUTPUT reports and DMIS output files are written in.
  void set_report_units(ReportUnits units) { m_report_units = std::move(units); }
  /// WKPLAN: the plane of polar coordinates from here on (CORTOL RADIUS and ANGLE, POL positions).
  void set_working_plane(WorkingPlane plane) { m_working_plane = plane; }
  WorkingPlane working_plane() const { return m_working_plane; }
  /// Strict reading (`--strict`): a tolerance that cannot be evaluated stops the run; read
  /// leniently (the default) it is left out of its OUTPUT with a warning, as shop software goes on.
  void set_strict(bool strict) { m_strict = strict; }
  [[nodiscard]] const ReportUnits& report_units() const { return m_report_units; }
  /// PUSH/word and POP/word: the state a word names saved on its own stack, and restored from it
  /// (runtime/src/pushed_state.cpp). Words: ALGN (the current alignment), SNSLCT (the sensor),
  /// WKPLAN, SNSET (the probing distances), GEOALG (the fitting algorithms).
  static bool pushable(std::string_view word);
  void push_state(const std::string& word);
  /// An error when no PUSH of `word` is left to restore.
  Result<void> pop_state(const std::string& word, Span span);
  [[nodiscard]] Mode mode() const { return m_mode; }
  /// The sensor the last SNSLCT selected ('' before any).
  [[nodiscard]] const std::string& active_sensor() const { return m_active_sensor; }
  Result<void> go_to(const Vec3& point_current, Span span);
  /// GOHOME: straight to the machine's home; a warning when the backend does not say where it is.
  Result<void> go_home(Span span);
  /// FROM: where GOHOME goes from now on (current coordinates, kept as a machine point).
  void set_home(const Vec3& point_current) { m_program_home = m_alignment.to_machine_point(point_current); }
  /// Current ball-centre position in the current frame.
  [[nodiscard]] Vec3 position_current() const;
  Result<void> measure(const MeasBlock& block);

  // Scanning (runtime/src/scan.cpp, docs/scanning-paths.md).
  /// P(label)=PATH/...: points and vectors in the current frame.
  Result<void> define_path(PathDefinition path_current, Span span);
  [[nodiscard]] const std::map<std::string, PathDefinition>& paths() const { return m_paths; }
  ScanSettings& scan_settings() { return m_scan; }

  // Alignments and datums.
  [[nodiscard]] const Alignment& alignment() const { return m_alignment; }
  Result<void> define_datum(const FeatureRef& feature, const std::string& datum, Span span);
  Result<void> datset(const std::string& label, const DatsetRequest& request, Span span);
  Result<void> trans(const std::string& label, const TransRequest& request, Span span);
  /// SNSET/CLRSRF,F(label),offset: the plane feature moved `offset_mm` along its normal becomes
  /// the clearance surface of AUTO moves (an error for a feature that is no plane).
  Result<void> set_clearance_surface(const FeatureRef& plane, double offset_mm, Span span);
  Result<void> rotate(const std::string& label, const RotateRequest& request, Span span);
  Result<void> save(const std::string& label, Span span);
  Result<void> recall(const std::string& label, Span span);
  /// LOCATE: D(label) = the frame that lays the features' nominals, as the program wrote them,
  /// closest to their actuals (least squares, moving only as the request allows, along and
  /// about the current frame's axes); it becomes the current alignment, and a note tells the
  /// motion and each feature's residual (runtime/src/best_fit_alignment.cpp).
  Result<void> locate(const std::string& label, const LocateRequest& request, Span span);
  /// ITERAT: one fit of an iterative alignment: D(label) = LOCATE's six-freedom best fit of the
  /// features, made current. Returns what the convergence test compares with its accuracy (mm):
  /// the features' largest distance from their nominals in the alignment they were measured in
  /// (ABSL), or how far the fit moved their nominals (`incremental`, INCR).
  Result<double> iterate(const std::string& label, const LocateRequest& request, bool incremental, Span span);

  // A part's set-ups (runtime/src/setups.cpp, docs/alignments.md).
  /// PAUSE: the program waits for its operator; what the machine says its operator did (a
  /// virtual CMM's operator may put the part in its next set-up) is noted, and the moment is
  /// remembered: the part may have been moved then (EQUATE cuts the set-ups there).
  void operator_stop(Span span);
  /// EQUATE/DA(earlier),DA(later): the part was moved between two set-ups, and DA(earlier) and
  /// DA(later) are the same part frame measured in each. The transformation T = later * earlier^-1
  /// carries what the earlier set-up measured to where it lies in the later one: every feature
  /// and datum whose actual rests on points taken before the cut (actual, points, nominal), and
  /// every coordinate system resting on such points (the current one included). With PAUSEs
  /// between DA(earlier)'s first point and DA(later)'s, the earlier set-up is what was measured
  /// between the PAUSEs around DA(earlier)'s first point (with what earlier EQUATEs carried into
  /// it); without, what rests on points taken before DA(later)'s first point. A note tells the
  /// motion and how many were carried; a DMIS output file open gets the statement as a comment
  /// line.
  Result<void> equate(const std::string& earlier, const std::string& later, Span span);

  // Constructions and outputs.
  /// CONST/POINT,F(l),MOVEPT,FA(x),dx,dy,dz: FA(x)'s position moved by an offset (current frame, mm).
  Result<void> construct_moved_point(const std::string& label, const FeatureRef& source, const Vec3& offset_current,
                                     Span span);
  /// CONST/POINT,F(l),EXTREM: the measured (compensated) point of FA(x) furthest along a
  /// direction, least far with `minimum`: `axis`'s direction, else `direction_current`.
  Result<void> construct_extreme_point(const std::string& label, const FeatureRef& source,
                                       const std::optional<FeatureRef>& axis, const Vec3& direction_current,
                                       bool minimum, Span span);
  /// CONST/POINT,F(l),EXTREM,...,RADIAL: the measured (compensated) point of FA(x) furthest from
  /// its own axis (circle, arc, cylinder, cone) or centre (sphere), nearest with `minimum`.
  Result<void> construct_radial_extreme_point(const std::string& label, const FeatureRef& source, bool minimum,
                                              Span span);
  /// CONST/PLANE,F(l),OFFSET,FA(plane),d: the plane moved d (mm) along its normal.
  Result<void> construct_offset_plane(const std::string& label, const FeatureRef& source, double distance_mm,
                                      Span span);
  /// CONST/CIRCLE,F(x),CONE,FA(cone),DIAM,d | DIST,h: the cone's circle of diameter d (a
  /// countersink's gauge diameter), or its circle h from the vertex along the axis.
  Result<void> construct_cone_section(const std::string& label, const FeatureRef& source, bool by_diameter,
                                      double value_mm, Span span);
  /// CONST/LINE|CIRCLE,F(l),TANTO,...: a LINE tangent to two circles (arcs, cylinders along the
  /// circle's axis, spheres' outlines) or to one and through a point; a CIRCLE of `diameter_mm`
  /// tangent to two lines, or tangent to three (runtime/src/construct_tangent.cpp). Of the
  /// solutions, the one nearest F(l)'s nominal; without one, a documented choice and a warning.
  Result<void> construct_tangent(const std::string& label, FeatureType type, const std::vector<FeatureRef>& sources,
                                 std::optional<double> diameter_mm, Span span);
  Result<void> construct(const std::string& label, FeatureType type, ConstructMethod method,
                         const std::vector<FeatureRef>& sources, Span span);
  /// OUTPUT: reports the features and evaluates and reports the tolerances (against the features
  /// of the same OUTPUT; a tolerance alone reports what the last EVAL of it found).
  Result<void> output(const std::vector<OutputItem>& items, Span span);
  /// EVAL/FA(x),TA(t): evaluates the tolerances and keeps the results for a later OUTPUT/TA(t);
  /// nothing is reported.
  Result<void> evaluate(const std::vector<OutputItem>& items, Span span);
  /// What the last OUTPUT or EVAL of T(label) found (VALUE/TA(label),...), one result per
  /// evaluation; null before the first.
  [[nodiscard]] const std::vector<ToleranceResult>* last_tolerance_results(const std::string& label) const;
  Result<void> define_device(const std::string& label, const std::string& path, Span span);
  /// OPEN/DID(l),FDATA|DIRECT,...,OUTPUT: an output file in the run's directory. A DIRECT file
  /// receives WRITE lines only; the others (FDATA, DMIS output files) OUTPUT and TEXT/OUTFIL too.
  Result<void> open_device(const std::string& label, Span span, bool direct = false);
  Result<void> close_device(const std::string& label, Span span);
  /// OPEN/DID(l),...,INPUT: the text of the device's file, found as written (absolute) or in the
  /// program's folders (the read policy's folders, in order), read under the read policy.
  Result<std::string> read_input_device(const std::string& label, Span span);
  /// WRITE/DID(l),...: one line into the device's output file (open for OUTPUT).
  Result<void> write_device(const std::string& label, const std::string& line, Span span);
  void text(const std::string& kind, const std::string& text);

  /// Records a machine fault with the statement that caused it (also emitted as an event).
  void record_fault(const machine::Fault& fault, Span span);
  /// Copies the feature store into the record (call at the end of a run).
  void finish();
  [[nodiscard]] machine::Machine& machine() { return m_machine; }

 private:
  void apply_fit_algorithm(Geometry& actual, const std::vector<MeasuredPoint>& points, const std::string& label,
                           Span span);
  void keep_failed_points(Feature& feature, const std::vector<MeasuredPoint>& points, Span span);
  /// A construction's actual; `rests_on_s`: the earliest of its sources' Feature::rests_on_s.
  void store_constructed(const std::string& label, const Geometry& actual, const std::optional<FitFigures>& figures,
                         double rests_on_s, Span span);
  void store_constructed_point(const std::string& label, const Vec3& position, const Vec3& direction, double rests_on_s,
                               Span span);
  Result<void> output_or_evaluate(const std::vector<OutputItem>& items, Span span, bool report_them);
  /// Tolerance `t` against `features` (one result; DISTWRT, ANGWRT and CORTOL: one per feature).
  Result<std::vector<ToleranceResult>> evaluate_tolerance(const std::string& t,
                                                          const std::vector<const Feature*>& features, Span span);
  struct Execution {
    std::vector<machine::Response> responses;
    std::optional<RuntimeError> error;
    std::uint64_t first_tag = 0;
  };
  Execution execute_commands(std::vector<machine::Command> commands, const std::vector<Span>& spans);
  Result<std::vector<machine::Response>> run_commands(std::vector<machine::Command> commands,
                                                      const std::vector<Span>& spans);
  Result<void> ensure_tool(Span span);
  /// The radius scanned samples of the active tool are compensated with: qualified once per tool
  /// by scanning the reference sphere's equator at the scan settings in force (docs/scanning.md,
  /// "Scanning-probe qualification"); the nominal radius when the tool has no touch qualification.
  Result<double> scanning_radius(Span span);
  std::map<std::string, double> m_scanning_radius_mm;  ///< tool name -> qualified scanning radius
  /// What plan_block reads: the settings and the machine's state now.
  [[nodiscard]] BlockPlanContext plan_context() const;
  /// A MEAS block's points from the machine's answers to its plan (touch hits with the dynamic
  /// correction, scan samples in contact); scan logs go to the machine log.
  std::vector<MeasuredPoint> collect_points(const BlockPlan& plan, const Execution& execution,
                                            const std::string& feature, Span block_span);
  Result<MeasBlock> relative_to_reference_surface(const MeasBlock& block, const Feature& feature);
  Result<Geometry> resolve(const FeatureRef& ref, Span span) const;  // MCS
  /// A construction's sources resolved (MCS), and the earliest of their Feature::rests_on_s.
  struct ResolvedSources {
    std::vector<Geometry> geometry;
    double rests_on_s = std::numeric_limits<double>::infinity();
  };
  Result<ResolvedSources> resolve_sources(const std::vector<FeatureRef>& sources, Span span) const;
  Result<const Datum*> datum(const std::string& label, Span span) const;
  void emit(RunEvent event);
  /// The matches of LOCATE's and ITERAT's features (runtime/src/best_fit_alignment.cpp).
  Result<std::vector<fitting::FrameMatch>> best_fit_matches(const std::string& statement, const LocateRequest& request,
                                                            Span span) const;
  void warn(Span span, const std::string& message);  ///< a positioned run-time warning in the record
  void note(Span span, const std::string& message);  ///< a positioned run-time note in the record
  void record(Span span, const char* severity, const std::string& message);  ///< the line of warn and note
  void write_device_line(const std::string& line);
  void output_sensor(const std::string& label, bool actual, Span span);
  void output_coordinate_system(const std::string& label, bool actual, Span span);
  [[nodiscard]] const Alignment* find_alignment(const std::string& label) const;
  /// Makes D(label) the current alignment; `rests_on_s`: Alignment::rests_on_s.
  /// `nominal_motion`: how far this system moves the nominals written so far (actual frame *
  /// nominal frame^-1); they are moved with it.
  void set_alignment(const std::string& label, const Frame& frame, double rests_on_s,
                     const Frame& nominal_motion = Frame::Identity());
  /// Moves every feature's and datum's nominal by `motion` (machine coordinates).
  void move_nominals(const Frame& motion);
  [[nodiscard]] double best_fit_rests_on_s(const LocateRequest& request) const;
  /// Feature::rests_on_s of FA(x); infinity for a nominal F(x).
  [[nodiscard]] double rests_on_s(const FeatureRef& ref) const;
  /// Sets the constructed F(label)'s Feature::construction_spread_mm from its sources.
  void set_construction_spread(const std::string& label, const std::vector<FeatureRef>& sources);

  machine::Machine& m_machine;
  const SourceManager& m_sources;
  RunRecord& m_record;
  std::function<void(const RunEvent&)> m_on_event;
  std::string m_output_dir = ".";
  FileAccessPolicy m_policy;
  std::vector<std::string> m_output_errors;
  WavefrontStationFactory m_wavefront_stations;  ///< CALIBRATE WAVEFRONT (set by the composition root)
  ErrorSpaceRig m_error_space_rig;               ///< CALIBRATE ERROR-SPACE (set by the composition root)

  std::map<std::string, Feature> m_features;
  std::vector<std::string> m_feature_order;
  std::map<std::string, ToleranceSpec> m_tolerances;
  std::map<std::string, std::vector<ToleranceResult>> m_evaluated;     ///< EVAL results, for OUTPUT/TA(t) alone
  std::map<std::string, std::vector<ToleranceResult>> m_last_results;  ///< last OUTPUT or EVAL, for VALUE/TA(t)
  std::map<std::string, Datum> m_datums;
  WorkingPlane m_working_plane = WorkingPlane::XY;
  std::map<std::string, Alignment> m_alignments;  ///< every D() defined, recallable
  std::map<std::string, Alignment> m_saved;       ///< SAVE/DA()
  std::vector<double> m_operator_stops_s;         ///< machine times of the PAUSEs, in order
  /// The set-up each set-up's measurements are in now (index: the PAUSEs before them), as
  /// EQUATE carried them; a set-up not listed is its own.
  std::vector<std::size_t> m_setup_carried_to;
  Alignment m_alignment;
  std::optional<Vec3> m_program_home;  ///< FROM's home, machine coordinates; else the machine's own
  std::map<std::string, SensorDefinition> m_sensors;
  std::map<std::string, machine::ToolInfo> m_tools;  ///< defined on the machine
  std::string m_active_sensor;
  /// The machine's feeds (positioning, measuring) before the program's first FEDRAT: DEFALT's.
  std::optional<std::pair<double, double>> m_default_feeds;
  ProbeSettings m_probe;
  ScanSettings m_scan;
  std::map<std::string, PathDefinition> m_paths;
  std::map<std::string, geometry::Mesh> m_models;  ///< CAD models loaded by PATH/SECTION, by path
  std::optional<MachineCharacterisation> m_characterisation;
  std::optional<TouchBaseline> m_touch_baseline;
  std::optional<double> m_measuring_feed_explicit;       ///< FEDRAT/MESVEL given by the program
  double m_qualification_feed_mm_s = 0;                  ///< measuring feed when the active tool was qualified
  std::map<FeatureType, FitAlgorithm> m_fit_algorithms;  ///< GEOALG: least squares where absent
  /// What PUSH saved, one stack per word (each POP restores its word's part).
  struct PushedState {
    Alignment alignment;
    std::string sensor;
    WorkingPlane working_plane = WorkingPlane::XY;
    ProbeSettings probe;
    std::map<FeatureType, FitAlgorithm> fit_algorithms;
    double positioning_feed_mm_s = 0, measuring_feed_mm_s = 0;  ///< FEDRAT: the machine's feeds
    std::optional<double> scan_feed_mm_s, measuring_feed_explicit;
  };
  std::map<std::string, std::vector<PushedState>> m_pushed;
  bool m_strict = false;              ///< set_strict
  bool m_feed_change_warned = false;  ///< a probing feed other than the qualification's, told once
  Mode m_mode = Mode::Auto;
  ReportUnits m_report_units;
  struct Device {
    std::string path;
    bool open = false;
    std::shared_ptr<std::ofstream> stream;
    std::string temp_path;  ///< written while open; renamed to `path` when closed (atomic output)
    bool direct = false;    ///< OPEN/...,DIRECT: a text file for WRITE only, no OUTPUT or TEXT/OUTFIL lines
  };
  /// Closes a device's stream and moves its temporary file into place; false (and an entry in
  /// m_output_errors) when a write failed.
  bool commit_device(Device& device);
  std::map<std::string, Device> m_devices;
  std::uint64_t m_next_tag = 1;
};

}  // namespace metron::runtime
