#pragma once
/// \file Recorded trajectories of a real robot (a log: a CSV file with a header), read and
/// resampled to the control period dt, as transitions (x_k, u_k, x_{k+1} - x_k) for
/// model::make_dataset. The one reader of logs; `drops identify` and runs that start from
/// recorded data use it. docs/logs.md says the same for users.
///
/// The file: a header line of column names, then one sample per line, cells separated by ','.
/// Lines that are empty or start with '#' are skipped; a trailing '\r' is ignored; header names
/// may be quoted ("time"); cells may be surrounded by spaces. Only the declared columns are
/// parsed (others may hold anything). Lines are counted from 1, the header included: "line 17"
/// is the 17th line of the file as an editor shows it.
///
/// The method (read_log and resample_log, in this order):
///  1. Rows. The declared columns of every row are parsed as numbers; an empty cell, "nan" or
///     "inf" is not finite: an error, or with LogOptions::bad_rows = kDrop the row is dropped
///     (counted). Time (time column x time_scale, s) must increase: a row whose time is below
///     the previous row's is an error; a row at the previous row's time is an error, or dropped
///     (counted) with kDrop.
///  2. Segments. Where two consecutive kept rows are more than LogOptions::max_gap apart (by
///     default the larger of dt and twice the median row interval), the log is split (counted
///     in LogReport::gaps); each segment is resampled on its own, and a segment shorter than one
///     period dt (no transition) is dropped (counted).
///  3. Angles. Each angle column is unwrapped in each segment: a step of more than pi between
///     consecutive rows is taken for a wrap and the nearest multiple of 2 pi is removed (numpy's
///     unwrap), so an angle logged in (-pi, pi] is interpolated through +-pi without a spurious
///     turn, and drops sees the continuous angle (as its states are: never wrapped). A step of
///     more than 3 pi is no wrap of an angle in radians: an error (degrees, or a glitch).
///  4. Fine grid. The states are linearly interpolated onto the uniform grid t_0 + j h of the
///     segment, h = dt / m with m = ceil(dt / median row interval), so that every k dt is a grid
///     point and h is no longer than the log's own sample interval. Without a low-pass, x_k is
///     thus exactly the linear interpolation of the rows at t_0 + k dt.
///  5. Low-pass (optional, LogOptions::lowpass_hz > 0): every state column is filtered on the
///     fine grid by a Butterworth filter of order LogOptions::lowpass_order (bilinear transform
///     with the cutoff prewarped, as second-order sections), run forward and backward (zero
///     phase), as scipy.signal's sosfiltfilt but with a longer odd extension: 6 / f_c seconds
///     at each end (at most N - 1 samples; sosfiltfilt's 3 (2 s + 1) samples leave the
///     transient of a ramp's lag in the data), each pass started at the steady state of its
///     first sample (with scipy's padlen set to the same length, the two agree to 2e-13). A
///     constant and a line pass unchanged. The forward-backward gain at frequency f is
///     1 / (1 + (tan(pi f h) / tan(pi f_c h))^(2 n)): 1/2 (-6 dB) at the cutoff.
///  6. Derived velocities (a LogState of kind kVelocity without a column): the Savitzky-Golay
///     derivative (Savitzky & Golay 1964; a least-squares quadratic over 2w + 1 grid points,
///     w = max(1, round(derivative_window / (2 h)))) of the (filtered) fine-grid signal of the
///     state it is the rate of; at the first and last w points, the derivative at that point of
///     the quadratic fitted to the first or last 2w + 1 points. Its gain at frequency f is about
///     3 (sin a - a cos a) / a^3 with a = 2 pi f w h (1 at low f; the noise is averaged over the
///     window).
///  7. States: x_k = the fine grid at t_0 + k dt, k = 0..K, K = floor((t_last - t_0) / dt).
///  8. Actions: zero-order hold (row i's action holds on [t_i, t_{i+1})) averaged over each
///     period: u_k = (1/dt) * integral over [t_0 + k dt, t_0 + (k+1) dt) of the held action,
///     exactly (rows that were not dropped only; the action is not low-passed: its average is
///     its filter).
///  9. Transitions (x_k, u_k, x_{k+1} - x_k), k = 0..K-1, per segment, in time order.
///
/// Checks of the units (LogReport says what they found):
///  - an angle step of more than 3 pi between rows (3 above);
///  - an angle column whose values span more than LogOptions::max_angle_span (rad; a swing of a
///    pendulum logged in degrees spans tens to hundreds);
///  - a logged velocity declared as the rate of a state (LogState::of): the least-squares slope
///    s of the derivative of that state (6) against the logged velocity, over every fine-grid
///    point, must lie in [0.5, 2] where the two are correlated (|correlation| >= 0.5; a log at
///    rest is not checked). s near 57.3 says the angle is in degrees, near 1/57.3 the velocity is
///    in degrees per second, near -1 the two have opposite signs.
///
/// Errors: drops::Error for the file and its contents, naming the file, the line and the column
/// (a missing column lists the file's columns); drops::InvalidArgument for a declaration or
/// options that are not valid (naming the field and the value). Nothing is written anywhere:
/// a log either reads whole or throws. Every function here is thread-safe (no shared state).

#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "drops/core/types.hpp"

namespace drops::experiment {

/// What a state column holds; it decides how it is interpolated and checked.
enum class LogQuantity {
  kAngle,     ///< an angle (rad): unwrapped, checked for degrees
  kVelocity,  ///< an angular (rad/s) or linear (m/s) velocity: logged, or derived from `of`
  kOther,     ///< any other quantity (a position in m, a temperature ...): interpolated as is
};

/// "angle" | "velocity" | "other". Thread-safe.
std::string to_string(LogQuantity q);

/// One state of the resampled trajectory (drops' state order is the order of LogColumns::state).
struct LogState {
  /// The file's column that holds it; empty only for a velocity derived from `of`.
  std::string column;
  LogQuantity quantity = LogQuantity::kOther;
  /// kVelocity: the state (its name) this is the rate of. With `column` empty, the velocity is
  /// its smoothed derivative (step 6); with a column, the logged velocity is checked against that
  /// derivative (the units check). Empty for other quantities.
  std::string of;
  /// The state's name in drops' files; empty: the column's name. Required for a derived
  /// velocity. Follows is_column_name.
  std::string name;
  /// The state's name: `name`, else `column`. Thread-safe.
  const std::string& state_name() const { return name.empty() ? column : name; }
};

/// Which columns of a log are time, the state and the action.
struct LogColumns {
  std::string time = "time";        ///< the time column (units: LogOptions::time_scale s)
  std::vector<LogState> state;      ///< dim E >= 1, in drops' state order
  std::vector<std::string> action;  ///< dim U >= 1, the action's columns in order
  /// Returns true when the declaration is valid: every column and state name follows
  /// is_column_name, state names are distinct, action columns distinct and none is a state's or
  /// the time column, a velocity's `of` names an angle or other state declared here, only a
  /// velocity has `of`, a derived velocity has a name. Otherwise false and the reason in *why.
  bool IsValid(std::string* why) const;
};

/// What read_log and resample_log do with bad rows.
enum class BadRows {
  kError,  ///< throw, naming the file, the line and the column
  kDrop,   ///< drop the row and count it (LogReport): the samples around it are interpolated
};

/// How a log is resampled (the method: this file's head).
struct LogOptions {
  double dt = 0.01;         ///< control period of the transitions (s), > 0
  double time_scale = 1.0;  ///< seconds per unit of the time column (1e-3 for ms, 1e-9 for ns), > 0
  /// A gap between consecutive rows longer than this splits the log (s), >= 0; 0: the larger of
  /// dt and twice the median row interval.
  double max_gap = 0.0;
  /// Rows with a value that is not finite (or empty) in a declared column, and rows at the
  /// previous row's time.
  BadRows bad_rows = BadRows::kError;
  double lowpass_hz =
      0.0;                ///< Butterworth cutoff (Hz), >= 0, below the fine grid's Nyquist; 0: off
  int lowpass_order = 2;  ///< Butterworth order, in [1, 8] (zero phase: twice that in effect)
  /// Window of the Savitzky-Golay derivative of derived velocities (s), >= 0: 2w + 1 grid points
  /// with w = max(1, round(derivative_window / (2 h))); 0: the centred difference (w = 1).
  double derivative_window = 0.01;
  /// An angle column spanning more than this (rad) is refused (degrees?), > 0; +inf: no check.
  double max_angle_span = 50.0;
  /// The fewest transitions the log must give (after splitting and dropping), >= 1.
  int min_transitions = 1;
  /// Returns true when every field is in range; otherwise false and the reason in *why.
  bool IsValid(std::string* why) const;
};

/// A log's declared columns as numbers, before resampling: what read_log parses from a file and
/// what a caller holding arrays (Python's numpy) hands to resample_log.
struct LogTable {
  std::string source;                ///< the file's path or a name for messages
  std::vector<std::string> columns;  ///< the columns' names (the file's header)
  /// rows x columns values (NaN where a cell was empty or not finite). Columns not declared
  /// may hold anything.
  MatrixXd values;
  /// The file's line of each row (1-based, header included), for messages; empty: row i is
  /// called "row i+1".
  std::vector<int> lines;
  /// Index of a column, -1 when absent.
  int column(const std::string& name) const;
};

/// One stretch of the log without a gap, resampled.
struct LogSegment {
  double t0 = 0;       ///< time of x_0 (s, the time column times time_scale): its first row's
  MatrixXd x;          ///< (K + 1) x E states at t0 + k dt, k = 0..K
  MatrixXd u;          ///< K x U actions averaged over [t0 + k dt, t0 + (k+1) dt)
  int first_line = 0;  ///< the file's line of its first row
  int last_line = 0;   ///< the file's line of its last row
  int transitions() const { return static_cast<int>(u.rows()); }
};

/// What resampling found and did (every policy counted).
struct LogReport {
  std::string source;             ///< the file's path (or LogTable::source)
  int rows = 0;                   ///< data rows (header, blank and comment lines aside)
  int dropped_nonfinite = 0;      ///< rows dropped for a value that is not finite (BadRows::kDrop)
  int dropped_repeated_time = 0;  ///< rows dropped for repeating the previous time (kDrop)
  int gaps = 0;                   ///< gaps longer than max_gap: the log was split there
  double longest_interval = 0;    ///< longest interval between consecutive kept rows (s)
  double median_interval = 0;     ///< median interval between consecutive kept rows (s)
  double max_gap = 0;             ///< the gap threshold used (s)
  double grid_step = 0;           ///< h, the fine grid's step (s)
  int short_segments = 0;         ///< segments shorter than dt, dropped
  int short_segment_rows = 0;     ///< the rows they held
  int segments = 0;               ///< segments kept
  int transitions = 0;            ///< transitions in all kept segments
  /// Per state (dim E): wraps removed from an angle (step 3); 0 for other quantities.
  std::vector<int> angle_wraps;
  /// Per state (dim E): for a logged velocity with `of`, the slope of the derivative of `of`
  /// against it (the units check) and the RMS of their difference on the fine grid (its units);
  /// NaN otherwise, and the slope NaN also where the two were not correlated enough to check.
  std::vector<double> velocity_slope, velocity_rms_difference;
  /// One paragraph: "1000 transitions in 1 segment from 4997 rows (median interval 2 ms) ...".
  std::string BriefReport() const;
};

/// A log resampled to dt.
struct RecordedLog {
  std::vector<std::string> state_names;   ///< dim E (LogState::state_name)
  std::vector<std::string> action_names;  ///< dim U (the action's columns)
  double dt = 0;                          ///< the control period (s)
  std::vector<LogSegment> segments;       ///< in time order
  LogReport report;
  /// Every segment's transitions in order: x = x_k (dim E), u = u_k (dim U), dx = x_{k+1} - x_k.
  std::vector<Transition> transitions() const;
};

/// Reads the CSV log at `path` (read_file_text: a regular file of at most kMaxRunFileBytes) and
/// resamples it (resample_log). Throws drops::Error naming the file: it cannot be read, a line has
/// fewer cells than the header, a declared column is missing (a drops::ConfigError, the message
/// listing the file's columns) or named twice in the header, a cell is not a number (line and column), and every
/// error of resample_log; drops::InvalidArgument for an invalid declaration or options.
RecordedLog read_log(const std::filesystem::path& path, const LogColumns& columns,
                     const LogOptions& options = {});

/// Parses CSV text as read_log does (only the declared columns of `columns`, or every column
/// when `columns` declares none); `source` names it in messages. Throws as read_log.
LogTable parse_log_csv(const std::string& text, const std::string& source,
                       const LogColumns& columns);

/// Resamples a log's table to options.dt (the method: this file's head). Throws drops::Error
/// naming the source, the line and the column: a declared column missing, a value that is not
/// finite (BadRows::kError), time going backwards or repeating (kError), an angle step of more
/// than 3 pi, an angle spanning more than max_angle_span, a logged velocity whose slope against
/// the derivative of its `of` is outside [0.5, 2], fewer than 2 rows, dt shorter than the
/// median row interval (resampling would invent samples), fewer than min_transitions
/// transitions; drops::InvalidArgument for an invalid declaration or options.
RecordedLog resample_log(const LogTable& table, const LogColumns& columns,
                         const LogOptions& options = {});

// ---------------------------------------------------------------------------------------------
// The signal processing of the method, on a uniform grid of step h (s); each is tested on its own.

/// Zero-phase Butterworth low-pass (step 5): y filtered forward and backward by the order-n
/// Butterworth of cutoff cutoff_hz (sosfiltfilt's padding and initial conditions). y: dim N >= 1
/// (returned unchanged when N = 1). Throws InvalidArgument unless h > 0, 0 < cutoff_hz <
/// 1 / (2 h) and 1 <= order <= 8.
VectorXd butterworth_filtfilt(const VectorXd& y, double h, double cutoff_hz, int order);

/// Savitzky-Golay first derivative (step 6): at each point, the slope of the least-squares
/// quadratic over the 2w + 1 points centred on it (at the ends, the first or last 2w + 1 points,
/// evaluated at the point). y: dim N; returns dim N (units of y per s). Throws InvalidArgument
/// unless h > 0, w >= 1 and N >= 3 (with N < 2w + 1, w is lowered to (N - 1) / 2).
VectorXd savitzky_golay_derivative(const VectorXd& y, double h, int w);

}  // namespace drops::experiment
