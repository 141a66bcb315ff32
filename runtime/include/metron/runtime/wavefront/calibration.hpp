// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>
#include <tl/expected.hpp>

#include "metron/machine/wavefront/wavefront_machine.hpp"
#include "metron/runtime/wavefront/gauge_reading.hpp"
#include "metron/stdlib/wavefront/circle_fit.hpp"

/// The geometry calibration of SEEDS.md 5 on any `machine::wavefront::WavefrontMachine`: every
/// step uses gauge maps and axis commands only (ARCHITECTURE.md rule 1). docs/wavefront.md.
namespace metron::runtime::wavefront {

using machine::wavefront::AxisCommand;
using machine::wavefront::WavefrontMachine;

/// What the procedure knows about the machine so far; every step reads and extends it. Starts
/// from the design data.
struct Knowledge {
  Vec3 step_mm{1e-4, 1e-4, 1e-4};  ///< dx, dy, dz in use (nominal until calibrated)
  bool steps_calibrated = false;   ///< dx, dy from the gauge's lateral scale (axis-response)
  /// Gauge lateral (x, y) per machine step of X and Y (columns), mm per step: l_G = J d(steps).
  Eigen::Matrix2d lateral_per_step = Eigen::Matrix2d::Zero();
  Vec2 lateral_per_z_step{0, 0};              ///< gauge lateral mm per Z step (gauge axis vs Z)
  double gauge_clocking_rad = 0;              ///< gauge x from machine X about Z
  std::optional<double> focus_table_z_steps;  ///< Z that puts the table surface at the focus (cat's eye)
  std::optional<double> cat_eye_z_steps;      ///< Z of the cat's eye on the flat
  double cat_eye_height_mm = 0;               ///< the flat's face above the table (design)
  std::optional<Vec2> a_through_focus_steps;  ///< X, Y that put the A axis through the focus
  Vec2 az_correction_deg{0, 0};               ///< total B, C zero shifts applied by the A-Z alignment
  std::optional<double> zf_mm;                ///< B axis to the test ball's centre of curvature (B rotation)
  /// B and C rotations: stitch the nulls' maps and remove the part's own form from each null
  /// (docs/wavefront.md "The part's form in the rotation nulls"); false reads the raw nulls.
  bool remove_form = true;
  /// Instrumentation for tests and `--truth`: called with a tag ("focus:pom", ...) when the machine
  /// is in the state a recovered value refers to, so the caller can read its own truth there.
  std::function<void(const std::string&)> observe;
};

/// The design data and the initial knowledge from it.
Knowledge initial_knowledge(const WavefrontMachine& machine);

/// Observer of progress lines (for the CLI's stderr); may be empty.
using Log = std::function<void(const std::string&)>;

/// A null: the position where the gauge reads zero tilt and focus (the commanded position
/// corrected by the last reading's residual), and the last reading.
struct NullResult {
  Vec3 steps{0, 0, 0};   ///< null position estimate (X, Y, Z steps)
  GaugeReading reading;  ///< the last map's reading
  int maps = 0;          ///< maps used (search included)
};

/// Brings a mounted sphere confocal (tilt and focus to zero) with X, Y and Z, searching Z (then
/// X-Y) when the gauge cannot read (too many fringes or no return). With `z_only` (the cat's eye
/// on a flat) only the focus term is nulled, with Z.
tl::expected<NullResult, std::string> null_sphere(WavefrontMachine& m, const Knowledge& k, const Log& log = {},
                                                  bool z_only = false);

/// Options of part-on-mount.
struct PartOnMountOptions {
  std::vector<double> angles_deg{0, 60, 120, 180, 240, 300};  ///< spindle angles (>= 2)
  bool null_first = true;  ///< sphere: null at the first angle before turning the spindle
};

/// Part-on-mount (SEEDS.md 5, the core step): tilts at several spindle angles, circle fit.
struct PartOnMountResult {
  bool sphere = true;                      ///< transmission sphere (lateral, mm) or flat (angular, rad)
  std::vector<double> angles_deg;          ///< spindle angles measured
  std::vector<Vec2> tilts;                 ///< per angle: lateral mm (sphere) or angle rad (flat), gauge frame
  std::vector<Vec2> centroids_mm;          ///< flat: aperture centroid per angle, gauge frame
  metron::wavefront::PhasedCircle circle;  ///< the fit with known angles: centre = gauge to spindle
  std::optional<metron::wavefront::Circle2> geometric;             ///< the geometric fit without angles (>= 3 angles)
  std::optional<metron::wavefront::PhasedCircle> centroid_circle;  ///< flat: centre = A axis in the gauge frame (mm)
  double radius_of_curvature_mm = 0;                               ///< sphere: design R used for the angles below
  Vec2 gauge_to_spindle_rad{0, 0};  ///< the centre as an angle (sphere: atan(lateral / R))
  Vec2 spindle_to_part_rad{0, 0};   ///< the radius vector at the first angle, as an angle
  Vec3 steps{0, 0, 0};              ///< X, Y, Z at which the tilts were taken
  int maps = 0;
};

/// Runs part-on-mount on the mounted part with the current element.
tl::expected<PartOnMountResult, std::string> part_on_mount(WavefrontMachine& m, const Knowledge& k,
                                                           const PartOnMountOptions& o = {}, const Log& log = {});

/// Axis response: with a sphere nulled, moves X, Y, Z by +-`move_steps` and reads the gauge:
/// dx and dy against the wavelength (lateral scale s = sin_max), the gauge's clocking and its
/// axis' tilt to Z. Extends `k`.
struct AxisResponseResult {
  Vec3 step_mm{0, 0, 0};           ///< recovered dx, dy, dz (dz from the focus response, first order)
  double gauge_clocking_rad = 0;   ///< gauge x axis from machine X
  Vec2 gauge_axis_to_z_rad{0, 0};  ///< gauge lateral per Z travel (tilt of Z seen by the gauge)
  int maps = 0;
};
tl::expected<AxisResponseResult, std::string> axis_response(WavefrontMachine& m, Knowledge& k, double move_steps = 100,
                                                            const Log& log = {});

/// Step 2: aligning the gauge frame with a flat under the transmission flat: part-on-mount, then
/// tip/tilt the gauge mount by the circle centre; the centroid circle gives the A axis in gauge
/// coordinates.
struct GaugeFrameResult {
  PartOnMountResult before;       ///< part-on-mount before the correction
  Vec2 gauge_to_a_rad{0, 0};      ///< recovered gauge-to-spindle angle (the correction applied)
  Vec2 a_axis_in_gauge_mm{0, 0};  ///< centroid circle centre
  Vec2 residual_rad{0, 0};        ///< centre after the correction
  int maps = 0;
};
tl::expected<GaugeFrameResult, std::string> align_gauge_frame(WavefrontMachine& m, Knowledge& k,
                                                              const std::string& flat, const PartOnMountOptions& o = {},
                                                              const Log& log = {});

/// Step 3: the focus on the A axis: the cat's eye on a flat gives the focus Z, part-on-mount on a
/// ball gives the A axis from the focus, X and Y move it there.
struct FocusResult {
  double cat_eye_z_steps = 0;        ///< Z at the cat's eye on the flat
  double focus_table_z_steps = 0;    ///< cat's eye plus the flat's height: the table at the focus
  Vec2 focus_to_a_mm{0, 0};          ///< part-on-mount centre before the move (gauge frame)
  Vec2 a_through_focus_steps{0, 0};  ///< X, Y after the move
  Vec2 residual_mm{0, 0};            ///< part-on-mount centre after the move
  int maps = 0;
};
tl::expected<FocusResult, std::string> focus_on_axis(WavefrontMachine& m, Knowledge& k, const std::string& flat,
                                                     const std::string& ball, const PartOnMountOptions& o = {},
                                                     const Log& log = {});

/// Step 4: B rotation with re-nulls, and the least-squares fit of P, Q, R, S (docs/wavefront.md
/// "The B-rotation null"), with the Y adjustment giving B's tilt out of perpendicular to X-Z.
struct BRotationResult {
  std::vector<double> b_deg;           ///< B commands
  std::vector<Vec3> null_steps;        ///< X, Y, Z null per B (the part's form removed when Knowledge::remove_form)
  std::vector<Vec3> raw_null_steps;    ///< X, Y, Z where each map read zero tilt and focus (form included)
  std::vector<double> form_height_nm;  ///< the ball's form stitched from the nulls' maps (FormStitch::form_height_nm)
  double form_residual_rms_nm = 0;     ///< rms of the maps minus the stitched model
  double p_steps = 0, q = 0, r = 0, s = 0;  ///< P (eccentricity / dx), Q = xb/dx, R = zF/dx, S = dz/dx
  double eccentricity_mm = 0, xb_mm = 0, zf_mm = 0, dz_mm = 0;  ///< with dx from the axis response
  double b_axis_tilt_rad = 0;     ///< from the Y adjustment (sign: + when Y must increase with +B... see docs)
  double residual_rms_steps = 0;  ///< fit residual
  int maps = 0;
};
tl::expected<BRotationResult, std::string> b_rotation(WavefrontMachine& m, Knowledge& k, const std::string& ball,
                                                      std::vector<double> b_deg = {}, const Log& log = {});

/// Step 4 for C (the seed: steps e and f "adapt directly" to other rotary and translation pairs):
/// C (about X) turned with re-nulls in Y and Z, and the fit of P_y (eccentricity along Y / dy),
/// Q_c = yc/dy, R_c = (zF - zc)/dy, S_c = dz/dy (docs/wavefront.md "The C-rotation null"); with zF
/// from the B rotation it gives zc.
struct CRotationResult {
  std::vector<double> c_deg;           ///< C commands
  std::vector<Vec3> null_steps;        ///< X, Y, Z null per C (the part's form removed when Knowledge::remove_form)
  std::vector<Vec3> raw_null_steps;    ///< X, Y, Z where each map read zero tilt and focus (form included)
  std::vector<double> form_height_nm;  ///< the ball's form stitched from the nulls' maps (FormStitch::form_height_nm)
  double form_residual_rms_nm = 0;     ///< rms of the maps minus the stitched model
  double p_steps = 0, q = 0, r = 0, s = 0;  ///< P_y, Q_c, R_c in steps of dy; S_c = dz/dy
  double yc_mm = 0;                         ///< A axis from the C axis along Y
  double zf_minus_zc_mm = 0;                ///< C axis to the centre of curvature along Z
  std::optional<double> zc_mm;              ///< B to C along Z (needs zF from the B rotation)
  double residual_rms_steps = 0;
  int maps = 0;
};
tl::expected<CRotationResult, std::string> c_rotation(WavefrontMachine& m, Knowledge& k, const std::string& ball,
                                                      std::vector<double> c_deg = {}, const Log& log = {});

/// Step 5: A-Z alignment from part-on-mount at two or more heights, line fit, B/C zero correction,
/// repeated until A is parallel to Z.
struct AzIteration {
  std::vector<double> z_mm;       ///< table Z of each part's measurement
  std::vector<Vec2> a_offset_mm;  ///< A axis from the focus, machine x/y, per height
  Vec2 angle_rad{0, 0};           ///< recovered A-to-Z tilt (x/z, y/z) before this correction
  Vec2 correction_deg{0, 0};      ///< B and C zero shifts applied
};
struct AzResult {
  std::vector<AzIteration> iterations;
  bool converged = false;
  int maps = 0;
};
struct AzOptions {
  std::vector<std::string> balls;  ///< parts at two or more heights (default: every sphere)
  double tolerance_rad = 0.05e-6;  ///< stop when the recovered angle is below (about 3 sd of its noise)
  int max_iterations = 8;
  bool correct = true;  ///< apply the corrections (false: measure once)
  PartOnMountOptions part_on_mount;
  std::function<void(const AzIteration&)> on_iteration;  ///< observer after each iteration
};
tl::expected<AzResult, std::string> align_a_to_z(WavefrontMachine& m, Knowledge& k, const AzOptions& o,
                                                 const Log& log = {});

/// Reversal: part-on-mount with the part as mounted and turned 180 degrees on the table; half the
/// difference of the radius vectors is the part's wedge (or decentre), half the sum the table's.
struct ReversalResult {
  PartOnMountResult at_0, at_180;
  Vec2 part_rad{0, 0};   ///< flat: face-to-base wedge (gauge frame at the first angle); sphere: decentre in mm
  Vec2 table_rad{0, 0};  ///< flat: table tilt; sphere: table tilt times the centre's height, mm
  int maps = 0;
};
tl::expected<ReversalResult, std::string> reversal(WavefrontMachine& m, Knowledge& k, const std::string& part,
                                                   const PartOnMountOptions& o = {}, const Log& log = {});

/// The whole procedure in the order of docs/wavefront.md ("Order").
struct CalibrationReport {
  std::optional<GaugeFrameResult> gauge_frame;
  std::optional<AxisResponseResult> axis_response;
  std::optional<FocusResult> focus;
  std::optional<AzResult> a_to_z;
  std::optional<BRotationResult> b_rotation;
  std::optional<CRotationResult> c_rotation;
  std::optional<ReversalResult> reversal;
  std::optional<PartOnMountResult> part_on_mount;
  Knowledge knowledge;
  long maps = 0;
};

/// The steps by name (`remove_form`: Knowledge::remove_form): "part-on-mount", "gauge-frame", "axis-response", "focus",
/// "a-z", "b-rotation", "c-rotation", "reversal", "all".
tl::expected<CalibrationReport, std::string> calibrate(WavefrontMachine& m, const std::string& step,
                                                       const Log& log = {}, const AzOptions& az = {},
                                                       const std::function<void(const std::string&)>& observer = {},
                                                       bool remove_form = true);

/// The report as JSON (docs/wavefront.md "Results file").
nlohmann::json to_json(const CalibrationReport& r);

}  // namespace metron::runtime::wavefront
