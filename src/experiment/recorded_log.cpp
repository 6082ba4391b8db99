#include "drops/experiment/recorded_log.hpp"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <charconv>
#include <cmath>
#include <complex>
#include <map>
#include <set>

#include "drops/core/errors.hpp"
#include "drops/experiment/experiment.hpp"
#include "drops/experiment/run_directory.hpp"

namespace drops::experiment {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kPi = 3.14159265358979323846;
// Time comparisons on the grid (k dt against a row's time) allow this fraction of dt.
constexpr double kGridTolerance = 1e-9;

// A name from a file as messages show it: quoted, control and non-ASCII bytes escaped, at most
// 80 characters.
std::string shown_name(const std::string& s) {
  std::string q = "'";
  for (std::size_t i = 0; i < s.size() && i < 80; ++i) {
    const auto c = static_cast<unsigned char>(s[i]);
    if (c < 0x20 || c >= 0x7F)
      q += fmt::format("\\x{:02x}", c);
    else
      q += static_cast<char>(c);
  }
  return q + (s.size() > 80 ? "...'" : "'");
}

std::string trim(const std::string& s) {
  std::size_t b = 0, e = s.size();
  while (b < e && (s[b] == ' ' || s[b] == '\t')) ++b;
  while (e > b && (s[e - 1] == ' ' || s[e - 1] == '\t')) --e;
  return s.substr(b, e - b);
}

std::vector<std::string> split_cells(const std::string& line) {
  std::vector<std::string> cells;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = line.find(',', start);
    cells.push_back(
        line.substr(start, comma == std::string::npos ? std::string::npos : comma - start));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return cells;
}

// The columns a declaration needs, in the order they are first named.
std::vector<std::string> declared_columns(const LogColumns& c) {
  std::vector<std::string> names;
  const auto add = [&](const std::string& n) {
    if (!n.empty() && std::find(names.begin(), names.end(), n) == names.end()) names.push_back(n);
  };
  add(c.time);
  for (const auto& s : c.state) add(s.column);
  for (const auto& a : c.action) add(a);
  return names;
}

std::string column_list(const std::vector<std::string>& columns) {
  std::string out;
  for (std::size_t i = 0; i < columns.size() && i < 100; ++i)
    out += (i ? ", " : "") + shown_name(columns[i]);
  if (columns.size() > 100) out += fmt::format(", ... ({} columns)", columns.size());
  return out;
}

[[noreturn]] void missing_column(const std::string& source, const std::string& name,
                                 const std::string& role, const std::vector<std::string>& cols) {
  // A ConfigError (a drops::Error): the declaration, not the file, is what to change, and
  // `drops identify` exits with 2 for it.
  throw ConfigError(fmt::format("{}: no column {} (declared as {}); its columns are: {}", source,
                                shown_name(name), role, column_list(cols)));
}

std::string role_of(const LogColumns& c, const std::string& column) {
  if (column == c.time) return "the time";
  for (const auto& s : c.state)
    if (s.column == column) return "the state " + shown_name(s.state_name());
  return "an action";
}

// ---- signal processing ----

struct Section {
  double b0, b1, b2, a1, a2;  // a0 = 1; unit gain at DC
};

// Butterworth low-pass as second-order sections: analog prototype poles, cutoff prewarped, the
// bilinear transform s = (z - 1) / (z + 1), all zeros at z = -1.
std::vector<Section> butterworth_sections(double h, double cutoff_hz, int order) {
  const double wc = std::tan(kPi * cutoff_hz * h);
  std::vector<Section> sections;
  for (int k = 0; k < order / 2; ++k) {
    const std::complex<double> p =
        wc * std::exp(std::complex<double>(0, kPi * (2.0 * k + order + 1) / (2.0 * order)));
    const std::complex<double> z = (1.0 + p) / (1.0 - p);
    const double a1 = -2 * z.real(), a2 = std::norm(z);
    const double g = (1 + a1 + a2) / 4;
    sections.push_back({g, 2 * g, g, a1, a2});
  }
  if (order % 2 == 1) {
    const double z = (1 - wc) / (1 + wc);  // the real pole p = -wc
    const double g = (1 - z) / 2;
    sections.push_back({g, g, 0, -z, 0});
  }
  return sections;
}

// The cascade run over y in place (transposed direct form II), each section started at its
// steady state for a constant input y[0].
void sosfilt(const std::vector<Section>& sections, std::vector<double>& y) {
  for (const auto& s : sections) {
    double z2 = (s.b2 - s.a2) * y[0];
    double z1 = (s.b1 - s.a1) * y[0] + z2;
    for (double& v : y) {
      const double x = v;
      const double out = s.b0 * x + z1;
      z1 = s.b1 * x - s.a1 * out + z2;
      z2 = s.b2 * x - s.a2 * out;
      v = out;
    }
  }
}

// ---- resampling ----

// Linear interpolation of the rows (times t, values v) at t0 + j h, j = 0..J.
VectorXd interpolate(const std::vector<double>& t, const std::vector<double>& v, double h, int J) {
  VectorXd out(J + 1);
  std::size_t i = 0;
  for (int j = 0; j <= J; ++j) {
    const double tj = std::min(t[0] + j * h, t.back());
    while (i + 2 < t.size() && t[i + 1] <= tj) ++i;
    const double w = (tj - t[i]) / (t[i + 1] - t[i]);
    out[j] = v[i] + w * (v[i + 1] - v[i]);
  }
  return out;
}

// The period averages of the zero-order-held action (value v[i] on [t[i], t[i+1])) over
// [t0 + k dt, t0 + (k+1) dt), k = 0..K-1: exact integrals of a piecewise-constant function.
VectorXd period_averages(const std::vector<double>& t, const std::vector<double>& v, double dt,
                         int K) {
  // F(t[i]) = integral from t[0] to t[i].
  std::vector<double> F(t.size(), 0.0);
  for (std::size_t i = 1; i < t.size(); ++i) F[i] = F[i - 1] + v[i - 1] * (t[i] - t[i - 1]);
  std::size_t i = 0;
  const auto integral_to = [&](double a) {
    while (i + 1 < t.size() && t[i + 1] <= a) ++i;
    if (i + 1 == t.size()) return F[i];  // a = t.back() (within the grid tolerance)
    return F[i] + v[i] * (a - t[i]);
  };
  VectorXd out(K);
  double previous = integral_to(t[0]);
  for (int k = 0; k < K; ++k) {
    const double next = integral_to(std::min(t[0] + (k + 1) * dt, t.back()));
    out[k] = (next - previous) / dt;
    previous = next;
  }
  return out;
}

double median(std::vector<double> v) {
  const std::size_t n = v.size();
  std::nth_element(v.begin(), v.begin() + n / 2, v.end());
  const double hi = v[n / 2];
  if (n % 2 == 1) return hi;
  return (hi + *std::max_element(v.begin(), v.begin() + n / 2)) / 2;
}

std::string seconds_text(double s) {
  if (s != 0 && std::abs(s) < 0.1) return fmt::format("{:.4g} ms", s * 1e3);
  return fmt::format("{:.4g} s", s);
}

}  // namespace

std::string to_string(LogQuantity q) {
  switch (q) {
    case LogQuantity::kAngle:
      return "angle";
    case LogQuantity::kVelocity:
      return "velocity";
    case LogQuantity::kOther:
      return "other";
  }
  return "other";
}

bool LogColumns::IsValid(std::string* why) const {
  const auto fail = [&](const std::string& w) {
    if (why) *why = w;
    return false;
  };
  const std::string grammar =
      "is not a column name (1 to 64 of A-Z a-z 0-9 _ ., not starting with a digit or '.')";
  if (!is_column_name(time)) return fail("the time column " + shown_name(time) + " " + grammar);
  if (state.empty()) return fail("no state column declared (at least one is needed)");
  if (action.empty()) return fail("no action column declared (at least one is needed)");
  std::map<std::string, const LogState*> states;
  for (std::size_t i = 0; i < state.size(); ++i) {
    const LogState& s = state[i];
    const std::string which = fmt::format("state {}", i);
    if (!s.column.empty() && !is_column_name(s.column))
      return fail(which + ": the column " + shown_name(s.column) + " " + grammar);
    if (!s.name.empty() && !is_column_name(s.name))
      return fail(which + ": the name " + shown_name(s.name) + " " + grammar);
    if (s.column.empty()) {
      if (s.quantity != LogQuantity::kVelocity || s.of.empty())
        return fail(which + " has no column (only a velocity with `of` is derived)");
      if (s.name.empty()) return fail(which + ": a derived velocity needs a name");
    }
    if (s.column == time) return fail(which + " is the time column " + shown_name(time));
    if (!s.of.empty() && s.quantity != LogQuantity::kVelocity)
      return fail(which + " (" + shown_name(s.state_name()) + ", an " + to_string(s.quantity) +
                  ") has `of` " + shown_name(s.of) + ": only a velocity is the rate of a state");
    if (!states.emplace(s.state_name(), &s).second)
      return fail("the state name " + shown_name(s.state_name()) + " is declared twice");
  }
  for (const LogState& s : state) {
    if (s.of.empty()) continue;
    const auto it = states.find(s.of);
    if (it == states.end())
      return fail("the velocity " + shown_name(s.state_name()) + " is the rate of " +
                  shown_name(s.of) + ", which is not a declared state");
    if (it->second->quantity == LogQuantity::kVelocity)
      return fail("the velocity " + shown_name(s.state_name()) + " is the rate of " +
                  shown_name(s.of) + ", a velocity (it must be an angle or another quantity)");
  }
  std::set<std::string> actions;
  for (const auto& a : action) {
    if (!is_column_name(a)) return fail("the action column " + shown_name(a) + " " + grammar);
    if (a == time) return fail("the action column " + shown_name(a) + " is the time column");
    if (!actions.insert(a).second)
      return fail("the action column " + shown_name(a) + " is declared twice");
    for (const auto& s : state)
      if (s.column == a || s.state_name() == a)
        return fail("the action column " + shown_name(a) + " is also a state");
  }
  return true;
}

bool LogOptions::IsValid(std::string* why) const {
  const auto fail = [&](const std::string& w) {
    if (why) *why = w;
    return false;
  };
  const auto positive = [](double v) { return std::isfinite(v) && v > 0; };
  if (!positive(dt)) return fail(fmt::format("dt = {}: expected a finite number > 0 (s)", dt));
  if (!positive(time_scale))
    return fail(
        fmt::format("time_scale = {}: expected a finite number > 0 (s per unit)", time_scale));
  if (!(std::isfinite(max_gap) && max_gap >= 0))
    return fail(
        fmt::format("max_gap = {}: expected a finite number >= 0 (s; 0: default)", max_gap));
  if (!(std::isfinite(lowpass_hz) && lowpass_hz >= 0))
    return fail(
        fmt::format("lowpass_hz = {}: expected a finite number >= 0 (Hz; 0: off)", lowpass_hz));
  if (lowpass_order < 1 || lowpass_order > 8)
    return fail(fmt::format("lowpass_order = {}: expected 1 to 8", lowpass_order));
  if (!(std::isfinite(derivative_window) && derivative_window >= 0))
    return fail(fmt::format("derivative_window = {}: expected a finite number >= 0 (s)",
                            derivative_window));
  if (!(max_angle_span > 0))
    return fail(fmt::format("max_angle_span = {}: expected a number > 0 (rad; inf: no check)",
                            max_angle_span));
  if (min_transitions < 1)
    return fail(fmt::format("min_transitions = {}: expected at least 1", min_transitions));
  return true;
}

int LogTable::column(const std::string& name) const {
  const auto it = std::find(columns.begin(), columns.end(), name);
  return it == columns.end() ? -1 : static_cast<int>(it - columns.begin());
}

std::vector<Transition> RecordedLog::transitions() const {
  std::vector<Transition> out;
  for (const auto& s : segments) {
    for (int k = 0; k < s.transitions(); ++k) {
      out.push_back({s.x.row(k).transpose(), s.u.row(k).transpose(),
                     (s.x.row(k + 1) - s.x.row(k)).transpose()});
    }
  }
  return out;
}

std::string LogReport::BriefReport() const {
  std::string s = fmt::format(
      "{}: {} transitions in {} segment{} from {} rows (median interval {}, longest {})", source,
      transitions, segments, segments == 1 ? "" : "s", rows, seconds_text(median_interval),
      seconds_text(longest_interval));
  if (gaps)
    s += fmt::format("; split at {} gap{} longer than {}", gaps, gaps == 1 ? "" : "s",
                     seconds_text(max_gap));
  if (short_segments)
    s += fmt::format("; {} segment{} shorter than dt dropped ({} rows)", short_segments,
                     short_segments == 1 ? "" : "s", short_segment_rows);
  if (dropped_nonfinite)
    s += fmt::format("; {} rows with a value not finite dropped", dropped_nonfinite);
  if (dropped_repeated_time)
    s += fmt::format("; {} rows repeating the previous time dropped", dropped_repeated_time);
  int wraps = 0;
  for (int w : angle_wraps) wraps += w;
  if (wraps) s += fmt::format("; {} angle wraps unwrapped", wraps);
  return s;
}

LogTable parse_log_csv(const std::string& text, const std::string& source,
                       const LogColumns& columns) {
  LogTable table;
  table.source = source;
  std::vector<std::string> wanted = declared_columns(columns);
  const bool every = columns.state.empty() && columns.action.empty();
  std::vector<int> parse;  // indices of the columns to parse
  std::vector<std::vector<double>> rows;
  bool header = false;
  int line_no = 0;
  std::size_t pos = 0;
  while (pos < text.size()) {
    std::size_t end = text.find('\n', pos);
    if (end == std::string::npos) end = text.size();
    std::string line = text.substr(pos, end - pos);
    pos = end + 1;
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (trim(line).empty() || line[0] == '#') continue;
    std::vector<std::string> cells = split_cells(line);
    if (!header) {
      header = true;
      for (auto& c : cells) {
        c = trim(c);
        if (c.size() >= 2 && c.front() == '"' && c.back() == '"') c = c.substr(1, c.size() - 2);
      }
      table.columns = cells;
      if (every) {
        for (int i = 0; i < static_cast<int>(cells.size()); ++i) parse.push_back(i);
        continue;
      }
      for (const auto& name : wanted) {
        const auto n = std::count(cells.begin(), cells.end(), name);
        if (n == 0) missing_column(source, name, role_of(columns, name), cells);
        if (n > 1)
          throw Error(
              fmt::format("{} line {}: the column {} (declared as {}) is in the header "
                          "{} times",
                          source, line_no, shown_name(name), role_of(columns, name), n));
        parse.push_back(table.column(name));
      }
      continue;
    }
    if (cells.size() != table.columns.size())
      throw Error(fmt::format("{} line {}: {} cells, the header has {}", source, line_no,
                              cells.size(), table.columns.size()));
    std::vector<double> row(table.columns.size(), kNaN);
    for (int c : parse) {
      const std::string cell = trim(cells[c]);
      if (cell.empty()) continue;  // NaN: not finite, handled by resample_log's policy
      double v = kNaN;
      const char* first = cell.data() + (cell[0] == '+' ? 1 : 0);
      const auto [ptr, ec] = std::from_chars(first, cell.data() + cell.size(), v);
      if (ec == std::errc::result_out_of_range) {
        v = (cell[0] == '-' ? -1 : 1) * std::numeric_limits<double>::infinity();
      } else if (ec != std::errc() || ptr != cell.data() + cell.size()) {
        throw Error(fmt::format("{} line {}, column {}: {} is not a number", source, line_no,
                                shown_name(table.columns[c]), shown_name(cell)));
      }
      row[c] = v;
    }
    rows.push_back(std::move(row));
    table.lines.push_back(line_no);
  }
  if (!header) throw Error(source + " holds no header line (and no data)");
  table.values.resize(static_cast<Eigen::Index>(rows.size()),
                      static_cast<Eigen::Index>(table.columns.size()));
  for (std::size_t i = 0; i < rows.size(); ++i)
    for (std::size_t c = 0; c < rows[i].size(); ++c)
      table.values(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(c)) = rows[i][c];
  return table;
}

RecordedLog read_log(const std::filesystem::path& path, const LogColumns& columns,
                     const LogOptions& options) {
  std::string why;
  if (!columns.IsValid(&why)) throw InvalidArgument("log columns: " + why);
  if (!options.IsValid(&why)) throw InvalidArgument("log options: " + why);
  std::string text;
  try {
    text = read_file_text(path);
  } catch (const Error& e) {
    throw Error(file_error("log", e.what()));
  }
  return resample_log(parse_log_csv(text, path.string(), columns), columns, options);
}

RecordedLog resample_log(const LogTable& table, const LogColumns& columns,
                         const LogOptions& options) {
  std::string why;
  if (!columns.IsValid(&why)) throw InvalidArgument("log columns: " + why);
  if (!options.IsValid(&why)) throw InvalidArgument("log options: " + why);
  const std::string& src = table.source;
  if (table.values.cols() != static_cast<Eigen::Index>(table.columns.size()))
    throw InvalidArgument(fmt::format("{}: the table has {} columns of values, {} names", src,
                                      table.values.cols(), table.columns.size()));
  const int rows = static_cast<int>(table.values.rows());
  if (!table.lines.empty() && static_cast<int>(table.lines.size()) != rows)
    throw InvalidArgument(
        fmt::format("{}: {} line numbers for {} rows", src, table.lines.size(), rows));
  const auto where = [&](int row) {
    return table.lines.empty() ? fmt::format("row {}", row + 1)
                               : fmt::format("line {}", table.lines[row]);
  };

  // The columns.
  const auto index = [&](const std::string& name) {
    const int c = table.column(name);
    if (c < 0) missing_column(src, name, role_of(columns, name), table.columns);
    return c;
  };
  const int E = static_cast<int>(columns.state.size());
  const int U = static_cast<int>(columns.action.size());
  const int time_col = index(columns.time);
  std::vector<int> state_col(E, -1), action_col(U), of(E, -1);
  for (int e = 0; e < E; ++e) {
    if (!columns.state[e].column.empty()) state_col[e] = index(columns.state[e].column);
    for (int f = 0; f < E && !columns.state[e].of.empty(); ++f)
      if (columns.state[f].state_name() == columns.state[e].of) of[e] = f;
  }
  for (int a = 0; a < U; ++a) action_col[a] = index(columns.action[a]);
  std::vector<int> used = {time_col};
  for (int c : state_col)
    if (c >= 0) used.push_back(c);
  for (int c : action_col) used.push_back(c);

  RecordedLog log;
  log.dt = options.dt;
  for (const auto& s : columns.state) log.state_names.push_back(s.state_name());
  log.action_names = columns.action;
  LogReport& report = log.report;
  report.source = src;
  report.rows = rows;
  report.angle_wraps.assign(E, 0);
  report.velocity_slope.assign(E, kNaN);
  report.velocity_rms_difference.assign(E, kNaN);

  // 1. Rows: finite values, increasing time.
  std::vector<int> kept;
  std::vector<double> time;
  for (int r = 0; r < rows; ++r) {
    int bad = -1;
    for (int c : used)
      if (!std::isfinite(table.values(r, c))) {
        bad = c;
        break;
      }
    if (bad >= 0) {
      if (options.bad_rows == BadRows::kDrop) {
        ++report.dropped_nonfinite;
        continue;
      }
      throw Error(
          fmt::format("{} {}, column {}: {} is not a finite number (an empty cell, nan or inf); "
                      "bad_rows: drop drops such rows",
                      src, where(r), shown_name(table.columns[bad]),
                      std::isnan(table.values(r, bad)) ? "the value"
                                                       : fmt::format("{}", table.values(r, bad))));
    }
    const double t = table.values(r, time_col) * options.time_scale;
    if (!time.empty() && t <= time.back()) {
      if (t < time.back())
        throw Error(fmt::format("{} {}, column {}: time goes backwards ({} s after {} s at {})",
                                src, where(r), shown_name(columns.time), t, time.back(),
                                where(kept.back())));
      if (options.bad_rows == BadRows::kDrop) {
        ++report.dropped_repeated_time;
        continue;
      }
      throw Error(fmt::format(
          "{} {}, column {}: time repeats ({} s, as at {}); bad_rows: drop keeps the first row",
          src, where(r), shown_name(columns.time), t, where(kept.back())));
    }
    kept.push_back(r);
    time.push_back(t);
  }
  const int n = static_cast<int>(kept.size());
  if (n < 2)
    throw Error(fmt::format("{}: {} usable row{} of {} (at least 2 are needed to resample)", src, n,
                            n == 1 ? "" : "s", rows));

  // 2. Segments.
  std::vector<double> intervals(n - 1);
  for (int i = 0; i + 1 < n; ++i) intervals[i] = time[i + 1] - time[i];
  report.median_interval = median(intervals);
  report.longest_interval = *std::max_element(intervals.begin(), intervals.end());
  const double dt = options.dt;
  if (dt < report.median_interval * (1 - 1e-3))
    throw Error(fmt::format(
        "{}: dt = {} s is shorter than the log's median row interval ({}): resampling would "
        "invent samples between rows; use a dt of at least that",
        src, dt, seconds_text(report.median_interval)));
  const double max_gap =
      options.max_gap > 0 ? options.max_gap : std::max(dt, 2 * report.median_interval);
  report.max_gap = max_gap;
  const int m = std::max(1, static_cast<int>(std::ceil(dt / report.median_interval - 1e-9)));
  const double h = dt / m;
  report.grid_step = h;
  std::vector<std::pair<int, int>> segments;  // [first, last] kept-row indices
  int first = 0;
  for (int i = 0; i + 1 < n; ++i) {
    if (intervals[i] > max_gap) {
      ++report.gaps;
      segments.push_back({first, i});
      first = i + 1;
    }
  }
  segments.push_back({first, n - 1});

  const bool filter = options.lowpass_hz > 0;
  if (filter && !(options.lowpass_hz < 0.5 / h))
    throw InvalidArgument(fmt::format(
        "log options: lowpass_hz = {}: expected below the fine grid's Nyquist frequency {} Hz "
        "(grid step {})",
        options.lowpass_hz, 0.5 / h, seconds_text(h)));
  const int w = std::max(1, static_cast<int>(std::lround(options.derivative_window / (2 * h))));
  // Sums of the units check of each logged velocity: d (derivative of its `of`), v (logged).
  std::vector<double> sum_dv(E, 0), sum_dd(E, 0), sum_vv(E, 0), sum_diff2(E, 0);
  std::vector<long> count(E, 0);
  std::vector<double> angle_lo(E, kNaN), angle_hi(E, kNaN);
  std::vector<int> angle_lo_row(E, 0), angle_hi_row(E, 0);

  for (const auto& [a, b] : segments) {
    const int rows_in = b - a + 1;
    const double duration = time[b] - time[a];
    const int K = static_cast<int>(std::floor(duration / dt + kGridTolerance));
    if (K < 1) {
      ++report.short_segments;
      report.short_segment_rows += rows_in;
      continue;
    }
    const std::vector<double> t(time.begin() + a, time.begin() + b + 1);
    const int J = std::max(K * m, static_cast<int>(std::floor(duration / h + kGridTolerance)));
    // 3-5. Each state column on the fine grid: unwrapped, interpolated, filtered.
    std::vector<VectorXd> grid(E);
    for (int e = 0; e < E; ++e) {
      if (state_col[e] < 0) continue;
      std::vector<double> v(rows_in);
      double offset = 0;
      for (int i = 0; i < rows_in; ++i) {
        const int r = kept[a + i];
        double value = table.values(r, state_col[e]);
        if (columns.state[e].quantity == LogQuantity::kAngle && i > 0) {
          const double step = value + offset - v[i - 1];
          if (std::abs(step) > 3 * kPi)
            throw Error(fmt::format(
                "{} {}, column {}: the angle steps by {:.6g} from {} (more than 3 pi: no wrap "
                "of an angle in radians; is it in degrees?)",
                src, where(r), shown_name(columns.state[e].column), step, where(kept[a + i - 1])));
          if (std::abs(step) > kPi) {
            const double turns = std::round(step / (2 * kPi));
            offset -= 2 * kPi * turns;
            report.angle_wraps[e] += static_cast<int>(std::abs(turns));
          }
        }
        v[i] = value + offset;
        if (columns.state[e].quantity == LogQuantity::kAngle) {
          if (!(v[i] >= angle_lo[e])) angle_lo[e] = v[i], angle_lo_row[e] = r;
          if (!(v[i] <= angle_hi[e])) angle_hi[e] = v[i], angle_hi_row[e] = r;
        }
      }
      grid[e] = interpolate(t, v, h, J);
      if (filter)
        grid[e] = butterworth_filtfilt(grid[e], h, options.lowpass_hz, options.lowpass_order);
    }
    // 6. Derived velocities, and the units check of logged ones.
    for (int e = 0; e < E; ++e) {
      if (of[e] < 0) continue;
      const VectorXd& y = grid[of[e]];
      // A segment of one period on a grid of one step has two points: their slope.
      const VectorXd d = y.size() >= 3 ? savitzky_golay_derivative(y, h, w)
                                       : VectorXd::Constant(y.size(), (y[1] - y[0]) / h);
      if (state_col[e] < 0) {
        grid[e] = d;
        continue;
      }
      sum_dv[e] += d.dot(grid[e]);
      sum_dd[e] += d.squaredNorm();
      sum_vv[e] += grid[e].squaredNorm();
      sum_diff2[e] += (d - grid[e]).squaredNorm();
      count[e] += d.size();
    }
    // 7-8. States at k dt, actions averaged over each period.
    LogSegment seg;
    seg.t0 = t[0];
    seg.first_line = table.lines.empty() ? kept[a] + 1 : table.lines[kept[a]];
    seg.last_line = table.lines.empty() ? kept[b] + 1 : table.lines[kept[b]];
    seg.x.resize(K + 1, E);
    for (int e = 0; e < E; ++e)
      for (int k = 0; k <= K; ++k) seg.x(k, e) = grid[e][k * m];
    seg.u.resize(K, U);
    for (int c = 0; c < U; ++c) {
      std::vector<double> v(rows_in);
      for (int i = 0; i < rows_in; ++i) v[i] = table.values(kept[a + i], action_col[c]);
      seg.u.col(c) = period_averages(t, v, dt, K);
    }
    report.transitions += K;
    ++report.segments;
    log.segments.push_back(std::move(seg));
  }

  // The units checks over the whole log.
  for (int e = 0; e < E; ++e) {
    const LogState& s = columns.state[e];
    if (s.quantity == LogQuantity::kAngle && angle_hi[e] - angle_lo[e] > options.max_angle_span)
      throw Error(fmt::format(
          "{}, column {} (an angle): its values span {:.6g} rad ({} at {}, {} at {}), more than "
          "max_angle_span {} rad: is it in degrees? If the joint turns that far, raise "
          "max_angle_span",
          src, shown_name(s.column), angle_hi[e] - angle_lo[e], angle_lo[e], where(angle_lo_row[e]),
          angle_hi[e], where(angle_hi_row[e]), options.max_angle_span));
    if (count[e] == 0) continue;
    report.velocity_rms_difference[e] = std::sqrt(sum_diff2[e] / count[e]);
    if (sum_vv[e] == 0 || sum_dd[e] == 0) continue;
    const double correlation = sum_dv[e] / std::sqrt(sum_dd[e] * sum_vv[e]);
    if (std::abs(correlation) < 0.5) continue;
    const double slope = sum_dv[e] / sum_vv[e];
    report.velocity_slope[e] = slope;
    if (slope < 0.5 || slope > 2)
      throw Error(fmt::format(
          "{}, column {} (the velocity of {}): the derivative of {} is {:.4g} times it "
          "(expected about 1; 57.3 says the angle is in degrees, 0.0175 the velocity in "
          "degrees per second, -1 opposite signs)",
          src, shown_name(s.column), shown_name(s.of), shown_name(s.of), slope));
  }
  if (report.transitions < options.min_transitions)
    throw Error(fmt::format(
        "{}: {} transition{} at dt = {} s from {} rows ({} segment{} kept, {} shorter than dt "
        "dropped, {} gap{}), at least {} needed",
        src, report.transitions, report.transitions == 1 ? "" : "s", dt, rows, report.segments,
        report.segments == 1 ? "" : "s", report.short_segments, report.gaps,
        report.gaps == 1 ? "" : "s", options.min_transitions));
  return log;
}

VectorXd butterworth_filtfilt(const VectorXd& y, double h, double cutoff_hz, int order) {
  if (!(std::isfinite(h) && h > 0))
    throw InvalidArgument(fmt::format("butterworth_filtfilt: h = {}: expected > 0 (s)", h));
  if (!(cutoff_hz > 0 && cutoff_hz < 0.5 / h))
    throw InvalidArgument(
        fmt::format("butterworth_filtfilt: cutoff_hz = {}: expected in (0, {}) (below Nyquist)",
                    cutoff_hz, 0.5 / h));
  if (order < 1 || order > 8)
    throw InvalidArgument(fmt::format("butterworth_filtfilt: order = {}: expected 1 to 8", order));
  const int N = static_cast<int>(y.size());
  if (N <= 1) return y;
  const std::vector<Section> sections = butterworth_sections(h, cutoff_hz, order);
  // The odd extension: scipy.signal.sosfiltfilt's 3 (2 s + 1) samples (3 fewer with a
  // first-order section) are too few for the transient of a ramp's lag to die out before the
  // data (it starts at the lag, about 0.2 / f_c times the slope for order 2): 6 / f_c seconds,
  // over which the slowest pole's transient decays by e^-7 (order 8) or more; at most N - 1.
  const int s = static_cast<int>(sections.size());
  const int pad = std::min(N - 1, std::max(3 * (2 * s + 1 - (order % 2)),
                                           static_cast<int>(std::ceil(6 / (cutoff_hz * h)))));
  std::vector<double> ext(N + 2 * pad);
  for (int i = 0; i < pad; ++i) ext[i] = 2 * y[0] - y[pad - i];
  for (int i = 0; i < N; ++i) ext[pad + i] = y[i];
  for (int i = 0; i < pad; ++i) ext[pad + N + i] = 2 * y[N - 1] - y[N - 2 - i];
  sosfilt(sections, ext);
  std::reverse(ext.begin(), ext.end());
  sosfilt(sections, ext);
  std::reverse(ext.begin(), ext.end());
  VectorXd out(N);
  for (int i = 0; i < N; ++i) out[i] = ext[pad + i];
  return out;
}

VectorXd savitzky_golay_derivative(const VectorXd& y, double h, int w) {
  if (!(std::isfinite(h) && h > 0))
    throw InvalidArgument(fmt::format("savitzky_golay_derivative: h = {}: expected > 0 (s)", h));
  if (w < 1)
    throw InvalidArgument(fmt::format("savitzky_golay_derivative: w = {}: expected >= 1", w));
  const int N = static_cast<int>(y.size());
  if (N < 3)
    throw InvalidArgument(
        fmt::format("savitzky_golay_derivative: {} points: expected at least 3 (a quadratic)", N));
  w = std::min(w, (N - 1) / 2);
  const int L = 2 * w + 1;
  // weights.row(e + w): the derivative at offset e in [-w, w] from the window's centre, per
  // point of the window, of the least-squares quadratic in the offset (units of grid steps).
  Eigen::MatrixXd V(L, 3);
  for (int o = -w; o <= w; ++o) V.row(o + w) << 1.0, o, static_cast<double>(o) * o;
  const Eigen::MatrixXd pinv = (V.transpose() * V).ldlt().solve(V.transpose());  // 3 x L
  Eigen::MatrixXd weights(L, L);
  for (int e = -w; e <= w; ++e) weights.row(e + w) = pinv.row(1) + 2.0 * e * pinv.row(2);
  VectorXd d(N);
  for (int j = 0; j < N; ++j) {
    const int centre = std::clamp(j, w, N - 1 - w);
    d[j] = weights.row(j - centre + w).dot(y.segment(centre - w, L)) / h;
  }
  return d;
}

}  // namespace drops::experiment
