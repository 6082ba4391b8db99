// Recorded logs (drops/experiment/recorded_log.hpp): resampling against closed forms (a known
// signal at irregular times, the exact integral of a held action, the analytic derivative of a
// noisy sinusoid, the Butterworth filter's gain), each bad input's error, and a real robot's log.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "drops/core/errors.hpp"
#include "drops/experiment/recorded_log.hpp"

using namespace drops;
using namespace drops::experiment;
namespace fs = std::filesystem;

namespace {

constexpr double kPi = 3.14159265358979323846;

class TempDir {
 public:
  TempDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = fs::temp_directory_path() /
            (std::string("drops-test-log-") + info->name() + "-" + std::to_string(::getpid()));
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() { fs::remove_all(path_); }
  fs::path file(const std::string& name, const std::string& text) const {
    const fs::path p = path_ / name;
    std::ofstream(p) << text;
    return p;
  }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

// Irregular sample times from 0 to at least `end`: steps of mean_step * (0.5 + uniform[0, 1)).
std::vector<double> irregular_times(double end, double mean_step, unsigned seed) {
  std::mt19937_64 gen(seed);
  std::uniform_real_distribution<double> uniform(0.5, 1.5);
  std::vector<double> t = {0.0};
  while (t.back() < end) t.push_back(t.back() + mean_step * uniform(gen));
  return t;
}

// A log's CSV text: time, then one column per function of time.
std::string csv(const std::vector<double>& t, const std::vector<std::string>& names,
                const std::vector<std::function<double(int, double)>>& columns) {
  std::string s = "time";
  for (const auto& n : names) s += "," + n;
  s += "\n";
  for (int i = 0; i < static_cast<int>(t.size()); ++i) {
    s += fmt::format("{:.17g}", t[i]);
    for (const auto& f : columns) s += fmt::format(",{:.17g}", f(i, t[i]));
    s += "\n";
  }
  return s;
}

// The declaration of a pendulum's log: angle, its velocity (logged), action.
LogColumns pendulum_columns(bool derive_velocity = false) {
  LogColumns c;
  c.state.push_back({"theta", LogQuantity::kAngle, "", ""});
  if (derive_velocity)
    c.state.push_back({"", LogQuantity::kVelocity, "theta", "omega"});
  else
    c.state.push_back({"omega", LogQuantity::kVelocity, "theta", ""});
  c.action = {"u"};
  return c;
}

// The message of the drops::Error that f throws ("" when it throws none).
std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

// The known signal: a sum of two sinusoids, its derivatives, and a held action.
double theta(double t) {
  return 0.8 * std::sin(2 * kPi * 0.7 * t) + 0.3 * std::cos(2 * kPi * 1.9 * t);
}
double omega(double t) {
  return 0.8 * 2 * kPi * 0.7 * std::cos(2 * kPi * 0.7 * t) -
         0.3 * 2 * kPi * 1.9 * std::sin(2 * kPi * 1.9 * t);
}
// Bounds of |theta''| and |omega''| (the sums of the amplitudes times the frequencies' powers).
const double kThetaSecond = 0.8 * std::pow(2 * kPi * 0.7, 2) + 0.3 * std::pow(2 * kPi * 1.9, 2);
const double kOmegaSecond = 0.8 * std::pow(2 * kPi * 0.7, 3) + 0.3 * std::pow(2 * kPi * 1.9, 3);
// A piecewise-constant action: a new value at every row.
double action(int i) { return std::sin(0.37 * i) + 0.1 * (i % 7); }

}  // namespace

TEST(RecordedLog, StatesAtIrregularTimesAreInterpolatedWithinTheLinearInterpolationBound) {
  TempDir dir;
  const auto t = irregular_times(5.0, 0.002, 1);
  const fs::path p = dir.file("log.csv", csv(t, {"theta", "omega", "u"},
                                             {[](int, double s) { return theta(s); },
                                              [](int, double s) { return omega(s); },
                                              [](int i, double) { return action(i); }}));
  LogOptions o;
  o.dt = 0.01;
  const RecordedLog log = read_log(p, pendulum_columns(), o);
  ASSERT_EQ(log.segments.size(), 1u);
  const LogSegment& s = log.segments[0];
  const int K = static_cast<int>(std::floor(t.back() / 0.01 + 1e-9));
  EXPECT_EQ(s.transitions(), K);
  EXPECT_EQ(log.report.transitions, K);
  EXPECT_EQ(s.first_line, 2);
  EXPECT_EQ(s.last_line, static_cast<int>(t.size()) + 1);
  // Linear interpolation between rows at most `gap` apart errs by at most gap^2 / 8 max|f''|.
  double gap = 0;
  for (std::size_t i = 1; i < t.size(); ++i) gap = std::max(gap, t[i] - t[i - 1]);
  const double tol_theta = gap * gap / 8 * kThetaSecond;  // about 6e-5 rad
  const double tol_omega = gap * gap / 8 * kOmegaSecond;  // about 2e-3 rad/s
  for (int k = 0; k <= K; ++k) {
    EXPECT_NEAR(s.x(k, 0), theta(k * 0.01), tol_theta) << "k = " << k;
    EXPECT_NEAR(s.x(k, 1), omega(k * 0.01), tol_omega) << "k = " << k;
  }
  const auto tr = log.transitions();
  ASSERT_EQ(static_cast<int>(tr.size()), K);
  EXPECT_EQ(tr[3].x, s.x.row(3).transpose());
  EXPECT_EQ(tr[3].dx, (s.x.row(4) - s.x.row(3)).transpose());
  EXPECT_EQ(tr[3].u[0], s.u(3, 0));
  EXPECT_EQ(log.state_names, (std::vector<std::string>{"theta", "omega"}));
  EXPECT_EQ(log.action_names, (std::vector<std::string>{"u"}));
  // The logged velocity is the derivative of the angle: the units check passes with a slope of
  // 1 (the derivative's gain, 1 - O((w h omega)^2)).
  EXPECT_NEAR(log.report.velocity_slope[1], 1.0, 0.01);
}

TEST(RecordedLog, ActionIsTheExactAverageOfTheHeldActionOverEachPeriod) {
  TempDir dir;
  const auto t = irregular_times(3.0, 0.003, 2);
  const fs::path p = dir.file("log.csv", csv(t, {"theta", "omega", "u"},
                                             {[](int, double s) { return theta(s); },
                                              [](int, double s) { return omega(s); },
                                              [](int i, double) { return action(i); }}));
  LogOptions o;
  o.dt = 0.02;
  const RecordedLog log = read_log(p, pendulum_columns(), o);
  const LogSegment& s = log.segments.at(0);
  ASSERT_GT(s.transitions(), 100);
  // The oracle: row i's action times the overlap of [t_i, t_{i+1}) with the period.
  for (int k = 0; k < s.transitions(); ++k) {
    const double a = k * o.dt, b = (k + 1) * o.dt;
    double integral = 0;
    for (std::size_t i = 0; i + 1 < t.size(); ++i)
      integral +=
          action(static_cast<int>(i)) * std::max(0.0, std::min(b, t[i + 1]) - std::max(a, t[i]));
    EXPECT_NEAR(s.u(k, 0), integral / o.dt, 1e-12) << "k = " << k;
  }
  // Worked by hand: actions 1.5 on [0, 4 ms), -2 on [4, 12 ms), 7 on [12, 20 ms); dt = 10 ms:
  // u_0 = (1.5 * 4 - 2 * 6) / 10 = -0.6, u_1 = (-2 * 2 + 7 * 8) / 10 = 5.2.
  LogTable table;
  table.source = "steps";
  table.columns = {"time", "theta", "omega", "u"};
  table.values.resize(4, 4);
  table.values << 0.0, 0, 0, 1.5, 0.004, 0, 0, -2.0, 0.012, 0, 0, 7.0, 0.020, 0, 0, 100.0;
  const RecordedLog steps = resample_log(table, pendulum_columns(), LogOptions{});
  ASSERT_EQ(steps.segments.at(0).transitions(), 2);
  EXPECT_NEAR(steps.segments[0].u(0, 0), -0.6, 1e-13);
  EXPECT_NEAR(steps.segments[0].u(1, 0), 5.2, 1e-13);
  // The shortest log: two rows one period apart, one transition (a derived velocity is their
  // slope).
  table.values.resize(2, 4);
  table.values << 0.0, 0.1, 0, 3.0, 0.01, 0.3, 0, 4.0;
  const RecordedLog two = resample_log(table, pendulum_columns(true), LogOptions{});
  ASSERT_EQ(two.report.transitions, 1);
  EXPECT_NEAR(two.segments[0].x(0, 1), 20.0, 1e-9);
  EXPECT_EQ(two.segments[0].u(0, 0), 3.0);
}

TEST(RecordedLog, WrappedAngleIsUnwrappedAndInterpolatedWithoutATurn) {
  TempDir dir;
  const auto t = irregular_times(4.0, 0.002, 3);
  // A joint spinning at about 3 rad/s, logged in (-pi, pi].
  const auto spin = [](double s) { return 3 * s + 0.5 * std::sin(s); };
  const fs::path p =
      dir.file("log.csv", csv(t, {"q", "u"},
                              {[&](int, double s) { return std::remainder(spin(s), 2 * kPi); },
                               [](int i, double) { return action(i); }}));
  LogColumns c;
  c.state = {{"q", LogQuantity::kAngle, "", ""}, {"", LogQuantity::kVelocity, "q", "dq"}};
  c.action = {"u"};
  const RecordedLog log = read_log(p, c, {});
  const LogSegment& s = log.segments.at(0);
  double gap = 0;
  for (std::size_t i = 1; i < t.size(); ++i) gap = std::max(gap, t[i] - t[i - 1]);
  for (int k = 0; k <= s.transitions(); ++k)
    EXPECT_NEAR(s.x(k, 0), spin(k * 0.01), gap * gap / 8 * 0.5 + 1e-12) << "k = " << k;
  EXPECT_EQ(log.report.angle_wraps[0],
            static_cast<int>(std::floor((spin(t.back()) + kPi) / (2 * kPi))));
  EXPECT_EQ(log.report.angle_wraps[1], 0);
  // The derived velocity sees no jump: within 1e-3 of 3 + 0.5 cos(t) everywhere.
  for (int k = 0; k <= s.transitions(); ++k)
    EXPECT_NEAR(s.x(k, 1), 3 + 0.5 * std::cos(k * 0.01), 1e-3) << "k = " << k;
}

TEST(RecordedLog, SmoothedDerivativeOfANoisySinusoidIsWithinItsNoiseOfTheAnalyticDerivative) {
  // theta = sin(2 pi 0.5 t) + N(0, sigma^2) noise at 500 Hz (irregular); the velocity derived
  // by the Savitzky-Golay derivative over 2w + 1 = 17 points of h = 2 ms (derivative_window
  // 0.032 s). Its noise at the interior points is sigma / (h sqrt(sum o^2)) = sigma / (h
  // sqrt(408)) = 0.025 rad/s for sigma = 1e-3 rad; its bias (gain 1 - (2 pi f w h)^2 / 10) is
  // below 1e-3 rad/s.
  TempDir dir;
  const auto t = irregular_times(10.0, 0.002, 4);
  std::mt19937_64 gen(5);
  std::normal_distribution<double> noise(0.0, 1e-3);
  std::vector<double> noisy(t.size());
  for (std::size_t i = 0; i < t.size(); ++i) noisy[i] = std::sin(kPi * t[i]) + noise(gen);
  const fs::path p = dir.file(
      "log.csv", csv(t, {"theta", "u"},
                     {[&](int i, double) { return noisy[i]; }, [](int, double) { return 0.0; }}));
  LogOptions o;
  o.dt = 0.01;
  o.derivative_window = 0.032;
  const RecordedLog log = read_log(p, pendulum_columns(true), o);
  const LogSegment& s = log.segments.at(0);
  ASSERT_NEAR(log.report.grid_step, 0.002, 1e-4);
  double sum2 = 0, worst = 0;
  int n = 0;
  for (int k = 0; k <= s.transitions(); ++k) {
    const double err = s.x(k, 1) - kPi * std::cos(kPi * k * 0.01);
    if (k * 0.01 < 0.016 || k * 0.01 > t.back() - 0.016) continue;  // edge fits: one-sided
    sum2 += err * err;
    worst = std::max(worst, std::abs(err));
    ++n;
  }
  const double sigma_d = 1e-3 / (0.002 * std::sqrt(408.0));
  // Interpolating irregular rows onto the grid averages neighbouring noise (lowers it);
  // measured RMS 0.019 rad/s, largest 0.07.
  EXPECT_LT(std::sqrt(sum2 / n), 1.2 * sigma_d);
  EXPECT_LT(worst, 5 * sigma_d);
  // (The centred difference over one grid step would have a noise of sigma / (h sqrt 2) = 0.35
  // rad/s, 14 times as much.)
  // The low-pass before it (5 Hz, order 2) lowers the noise further and keeps the 0.5 Hz signal.
  o.lowpass_hz = 5;
  const RecordedLog filtered = read_log(p, pendulum_columns(true), o);
  double sum2f = 0;
  for (int k = 0; k <= s.transitions(); ++k) {
    if (k * 0.01 < 0.016 || k * 0.01 > t.back() - 0.016) continue;
    const double err = filtered.segments[0].x(k, 1) - kPi * std::cos(kPi * k * 0.01);
    sum2f += err * err;
  }
  EXPECT_LT(std::sqrt(sum2f / n), 0.5 * std::sqrt(sum2 / n));
}

TEST(RecordedLog, SavitzkyGolayDerivativeIsExactOnAQuadraticAtEveryPointEndsIncluded) {
  const int N = 40;
  const double h = 0.01;
  Eigen::VectorXd y(N), dy(N);
  for (int j = 0; j < N; ++j) {
    const double t = j * h;
    y[j] = 0.3 - 1.7 * t + 4.2 * t * t;
    dy[j] = -1.7 + 8.4 * t;
  }
  for (int w : {1, 3, 8, 30}) {
    const Eigen::VectorXd d = savitzky_golay_derivative(y, h, w);
    EXPECT_LT((d - dy).cwiseAbs().maxCoeff(), 1e-9) << "w = " << w;
  }
  // w = 1 in the interior is the centred difference.
  const Eigen::VectorXd d = savitzky_golay_derivative(y, h, 1);
  EXPECT_NEAR(d[5], (y[6] - y[4]) / (2 * h), 1e-12);
  EXPECT_THROW(savitzky_golay_derivative(y.head(2), h, 1), InvalidArgument);
  EXPECT_THROW(savitzky_golay_derivative(y, 0.0, 1), InvalidArgument);
}

TEST(RecordedLog, ButterworthForwardBackwardGainIsTheSquaredMagnitudeOfTheDigitalFilter) {
  // A sinusoid of frequency f through the order-n filter forward and backward: in the middle of
  // a long signal (transients gone) its amplitude is multiplied by
  // |H(f)|^2 = 1 / (1 + (tan(pi f h) / tan(pi fc h))^(2n)) and its phase is unchanged.
  const double h = 0.002, fc = 5.0;
  const int N = 5000;
  for (int order : {1, 2, 3, 4}) {
    for (double f : {1.0, 5.0, 12.0}) {
      Eigen::VectorXd y(N);
      for (int j = 0; j < N; ++j) y[j] = std::sin(2 * kPi * f * j * h);
      const Eigen::VectorXd out = butterworth_filtfilt(y, h, fc, order);
      const double gain =
          1 / (1 + std::pow(std::tan(kPi * f * h) / std::tan(kPi * fc * h), 2 * order));
      for (int j = N / 2 - 100; j < N / 2 + 100; ++j)
        ASSERT_NEAR(out[j], gain * y[j], 1e-6) << "order " << order << ", f = " << f;
    }
  }
  // A constant passes unchanged (unit gain at DC, started at its steady state), and so does a
  // line (the odd extension continues it).
  // The line's lag in the forward pass (about 1 here: the slope times the group delay) is a
  // transient at the extension's far end that has decayed below 1e-4 when the data begins.
  // (1000 points: 2 s, longer than the 6 / fc = 1.2 s extension.)
  Eigen::VectorXd c = Eigen::VectorXd::Constant(1000, 2.5), line(1000);
  for (int j = 0; j < 1000; ++j) line[j] = 1 + 0.01 * j;
  EXPECT_LT((butterworth_filtfilt(c, h, fc, 3) - c).cwiseAbs().maxCoeff(), 1e-12);
  for (int order : {1, 2, 5, 8})
    EXPECT_LT((butterworth_filtfilt(line, h, fc, order) - line).cwiseAbs().maxCoeff(), 1e-4)
        << "order " << order;
  EXPECT_THROW(butterworth_filtfilt(c, h, 250.0, 2), InvalidArgument);  // at Nyquist
  EXPECT_THROW(butterworth_filtfilt(c, h, fc, 9), InvalidArgument);
}

// ---- bad input: each error names the file, the line and the column, or is a counted policy ----

namespace {

// A short regular log at 100 Hz (10 rows per 0.1 s), rows as text to break one of them.
std::vector<std::string> rows_text(int n) {
  std::vector<std::string> rows;
  for (int i = 0; i < n; ++i)
    rows.push_back(fmt::format("{:.17g},{:.17g},{:.17g},{:.17g}", 0.01 * i, theta(0.01 * i),
                               omega(0.01 * i), action(i)));
  return rows;
}
std::string join(const std::vector<std::string>& rows, const std::string& header) {
  std::string s = header + "\n";
  for (const auto& r : rows) s += r + "\n";
  return s;
}
const std::string kHeader = "time,theta,omega,u";

}  // namespace

TEST(RecordedLog, MissingOrMisnamedColumnListsTheFilesColumns) {
  TempDir dir;
  const fs::path p = dir.file("log.csv", join(rows_text(20), "Time,theta,omega,u"));
  const std::string e = error_of([&] { read_log(p, pendulum_columns()); });
  EXPECT_NE(e.find(p.string()), std::string::npos) << e;
  EXPECT_NE(e.find("no column 'time' (declared as the time)"), std::string::npos) << e;
  EXPECT_NE(e.find("its columns are: 'Time', 'theta', 'omega', 'u'"), std::string::npos) << e;
  LogColumns c = pendulum_columns();
  c.time = "Time";
  c.action = {"tau"};
  const std::string e2 = error_of([&] { read_log(p, c); });
  EXPECT_NE(e2.find("no column 'tau' (declared as an action)"), std::string::npos) << e2;
  // A declared column twice in the header is ambiguous.
  const fs::path twice = dir.file("twice.csv", join(rows_text(20), "time,theta,omega,theta"));
  c = pendulum_columns();
  c.action = {"omega"};
  c.state.pop_back();
  const std::string e3 = error_of([&] { read_log(twice, c); });
  EXPECT_NE(e3.find("line 1: the column 'theta'"), std::string::npos) << e3;
  EXPECT_NE(e3.find("2 times"), std::string::npos) << e3;
}

TEST(RecordedLog, ValueThatIsNotFiniteIsAnErrorNamingLineAndColumnOrADroppedRowCounted) {
  TempDir dir;
  for (const std::string bad : {"nan", "inf", "-inf", "", "NaN"}) {
    auto rows = rows_text(40);
    rows[4] = fmt::format("0.04,{},{:.17g},{:.17g}", bad, omega(0.04), action(4));
    const fs::path p = dir.file("log.csv", join(rows, kHeader));
    const std::string e = error_of([&] { read_log(p, pendulum_columns()); });
    EXPECT_NE(e.find(p.string() + " line 6, column 'theta': "), std::string::npos)
        << "'" << bad << "': " << e;
    EXPECT_NE(e.find("not a finite number"), std::string::npos) << e;
    LogOptions o;
    o.bad_rows = BadRows::kDrop;
    const RecordedLog log = read_log(p, pendulum_columns(), o);
    EXPECT_EQ(log.report.dropped_nonfinite, 1);
    EXPECT_EQ(log.report.rows, 40);
    EXPECT_EQ(log.report.transitions, 39);  // the rows around it are interpolated across
    EXPECT_NE(log.report.BriefReport().find("1 rows with a value not finite dropped"),
              std::string::npos);
  }
  // A cell that is no number at all is always an error.
  auto rows = rows_text(40);
  rows[7] = "0.07,0.1,abc,0.5";
  const fs::path p = dir.file("text.csv", join(rows, kHeader));
  EXPECT_NE(error_of([&] {
              read_log(p, pendulum_columns());
            }).find(" line 9, column 'omega': 'abc' is not a number"),
            std::string::npos);
  // An undeclared column may hold anything.
  const fs::path extra = dir.file("extra.csv", join(rows_text(40), kHeader + ",note"));
  EXPECT_NE(error_of([&] {
              read_log(extra, pendulum_columns());
            }).find("line 2: 4 cells, the header has 5"),
            std::string::npos);
  std::string with_note = kHeader + ",note\n";
  for (const auto& r : rows_text(40)) with_note += r + ",some text\n";
  EXPECT_EQ(read_log(dir.file("note.csv", with_note), pendulum_columns()).report.transitions, 39);
}

TEST(RecordedLog, TimeGoingBackwardsIsAnErrorAndRepeatedTimeAnErrorOrDropped) {
  TempDir dir;
  auto rows = rows_text(40);
  rows[10] = fmt::format("0.085,{:.17g},{:.17g},1", theta(0.085), omega(0.085));
  const fs::path back = dir.file("back.csv", join(rows, kHeader));
  const std::string e = error_of([&] { read_log(back, pendulum_columns()); });
  EXPECT_NE(e.find(back.string() + " line 12, column 'time': time goes backwards (0.085 s after "
                                   "0.09 s at line 11)"),
            std::string::npos)
      << e;
  LogOptions drop;
  drop.bad_rows = BadRows::kDrop;
  EXPECT_NE(error_of([&] { read_log(back, pendulum_columns(), drop); }).find("backwards"),
            std::string::npos);

  rows = rows_text(40);
  rows.insert(rows.begin() + 10, fmt::format("0.09,0,0,5"));
  const fs::path repeat = dir.file("repeat.csv", join(rows, kHeader));
  const std::string e2 = error_of([&] { read_log(repeat, pendulum_columns()); });
  EXPECT_NE(e2.find(" line 12, column 'time': time repeats (0.09 s, as at line 11)"),
            std::string::npos)
      << e2;
  const RecordedLog log = read_log(repeat, pendulum_columns(), drop);
  EXPECT_EQ(log.report.dropped_repeated_time, 1);
  // The first row at that time is kept: the state at 0.09 s is the signal's, not the 0 of the
  // repeat.
  EXPECT_NEAR(log.segments.at(0).x(9, 0), theta(0.09), 1e-12);
}

TEST(RecordedLog, GapLongerThanTheThresholdSplitsTheLogAndIsCounted) {
  TempDir dir;
  auto rows = rows_text(200);
  rows.erase(rows.begin() + 50, rows.begin() + 60);    // 0.49 -> 0.60: a gap of 0.11 s
  rows.erase(rows.begin() + 120, rows.begin() + 122);  // 1.29 -> 1.32: a gap of 0.03 s
  const fs::path p = dir.file("gaps.csv", join(rows, kHeader));
  LogOptions o;
  o.max_gap = 0.05;
  const RecordedLog log = read_log(p, pendulum_columns(), o);
  EXPECT_EQ(log.report.gaps, 1);
  ASSERT_EQ(log.segments.size(), 2u);
  EXPECT_DOUBLE_EQ(log.segments[0].t0, 0.0);
  EXPECT_EQ(log.segments[0].transitions(), 49);
  EXPECT_EQ(log.segments[0].last_line, 51);
  EXPECT_NEAR(log.segments[1].t0, 0.60, 1e-12);
  EXPECT_EQ(log.segments[1].first_line, 52);
  EXPECT_NEAR(log.segments[1].x(0, 0), theta(0.60), 1e-12);
  EXPECT_EQ(log.report.transitions, 49 + 139);
  // The default threshold is the larger of dt and twice the median interval (0.02 s here).
  const RecordedLog split = read_log(p, pendulum_columns());
  EXPECT_EQ(split.report.gaps, 2);
  EXPECT_NEAR(split.report.max_gap, 0.02, 1e-12);
  // A segment shorter than dt holds no transition: dropped and counted.
  auto lone = rows_text(100);
  lone.erase(lone.begin() + 51, lone.begin() + 60);  // row 50 alone between two gaps
  const RecordedLog dropped =
      read_log(dir.file("lone.csv", join(lone, kHeader)), pendulum_columns(), o);
  EXPECT_EQ(dropped.report.gaps, 1);
  lone.erase(lone.begin() + 49);  // now row 50 is alone: gaps on both sides
  const RecordedLog alone =
      read_log(dir.file("alone.csv", join(lone, kHeader)), pendulum_columns(), [] {
        LogOptions g;
        g.max_gap = 0.015;
        return g;
      }());
  EXPECT_EQ(alone.report.gaps, 2);
  EXPECT_EQ(alone.report.short_segments, 1);
  EXPECT_EQ(alone.report.short_segment_rows, 1);
  EXPECT_EQ(alone.segments.size(), 2u);
}

TEST(RecordedLog, AngleInDegreesIsRefusedByEachOfTheThreeChecks) {
  TempDir dir;
  // 1. Wrapped degrees: a step of about 360 is no wrap of radians.
  const auto t = irregular_times(6.0, 0.002, 6);
  const auto spin = [](double s) { return 180 / kPi * std::remainder(3 * s, 2 * kPi); };
  const fs::path wrapped =
      dir.file("wrapped.csv",
               csv(t, {"q", "u"},
                   {[&](int, double s) { return spin(s); }, [](int, double) { return 0.0; }}));
  LogColumns c;
  c.state = {{"q", LogQuantity::kAngle, "", ""}};
  c.action = {"u"};
  const std::string e1 = error_of([&] { read_log(wrapped, c); });
  EXPECT_NE(e1.find(wrapped.string() + " line "), std::string::npos) << e1;
  EXPECT_NE(e1.find(", column 'q': the angle steps by "), std::string::npos) << e1;
  EXPECT_NE(e1.find("is it in degrees?"), std::string::npos) << e1;
  // 2. A swing of +-60 degrees spans 120 "rad".
  const fs::path swing = dir.file("swing.csv", csv(t, {"q", "u"},
                                                   {[](int, double s) { return 60 * std::sin(s); },
                                                    [](int, double) { return 0.0; }}));
  const std::string e2 = error_of([&] { read_log(swing, c); });
  EXPECT_NE(e2.find(", column 'q' (an angle): its values span 1"), std::string::npos) << e2;
  EXPECT_NE(e2.find("more than max_angle_span 50 rad: is it in degrees?"), std::string::npos) << e2;
  LogOptions wide;
  wide.max_angle_span = std::numeric_limits<double>::infinity();
  EXPECT_NO_THROW(read_log(swing, c, wide));
  // 3. A swing of +-20 degrees beside its velocity in rad/s: the derivative is 57.3 times it.
  const fs::path small =
      dir.file("small.csv", csv(t, {"theta", "omega", "u"},
                                {[](int, double s) { return 20 * std::sin(2 * s); },
                                 [](int, double s) { return 20 * kPi / 180 * 2 * std::cos(2 * s); },
                                 [](int, double) { return 0.0; }}));
  const std::string e3 = error_of([&] { read_log(small, pendulum_columns()); });
  EXPECT_NE(e3.find(", column 'omega' (the velocity of 'theta'): the derivative of 'theta' is 57."),
            std::string::npos)
      << e3;
  // A velocity of the opposite sign convention is refused too.
  const fs::path sign = dir.file(
      "sign.csv",
      csv(t, {"theta", "omega", "u"},
          {[](int, double s) { return std::sin(2 * s); },
           [](int, double s) { return -2 * std::cos(2 * s); }, [](int, double) { return 0.0; }}));
  EXPECT_NE(
      error_of([&] { read_log(sign, pendulum_columns()); }).find("the derivative of 'theta' is -"),
      std::string::npos);
}

TEST(RecordedLog, TooFewRowsOrTransitionsIsAnErrorSayingHowManyThereAre) {
  TempDir dir;
  const fs::path one = dir.file("one.csv", join(rows_text(1), kHeader));
  EXPECT_NE(error_of([&] {
              read_log(one, pendulum_columns());
            }).find(one.string() + ": 1 usable row of 1 (at least 2 are needed"),
            std::string::npos);
  const fs::path header = dir.file("header.csv", kHeader + "\n");
  EXPECT_NE(error_of([&] { read_log(header, pendulum_columns()); }).find("0 usable rows of 0"),
            std::string::npos);
  const fs::path empty = dir.file("empty.csv", "");
  EXPECT_NE(error_of([&] { read_log(empty, pendulum_columns()); }).find("holds no header line"),
            std::string::npos);
  LogOptions o;
  o.min_transitions = 100;
  const fs::path short_log = dir.file("short.csv", join(rows_text(50), kHeader));
  EXPECT_NE(error_of([&] { read_log(short_log, pendulum_columns(), o); })
                .find(": 49 transitions at dt = 0.01 s from 50 rows (1 segment kept, 0 shorter "
                      "than dt dropped, 0 gaps), at least 100 needed"),
            std::string::npos);
  // A dt below the log's own interval would invent samples.
  o = {};
  o.dt = 0.005;
  EXPECT_NE(error_of([&] {
              read_log(short_log, pendulum_columns(), o);
            }).find("dt = 0.005 s is shorter than the log's median row interval (10 ms)"),
            std::string::npos);
}

TEST(RecordedLog, FileThatCannotBeReadAndInvalidDeclarationsAreRefusedBeforeReading) {
  TempDir dir;
  const std::string e = error_of([&] { read_log(dir.path(), pendulum_columns()); });
  EXPECT_NE(e.find("log " + dir.path().string() + " is not a regular file (a directory)"),
            std::string::npos)
      << e;
  EXPECT_NE(error_of([&] { read_log(dir.path() / "none.csv", pendulum_columns()); })
                .find("cannot read log " + (dir.path() / "none.csv").string() +
                      ": No such file or directory"),
            std::string::npos);
  const fs::path p = dir.file("log.csv", join(rows_text(20), kHeader));
  LogColumns c = pendulum_columns();
  c.state[0].column = "theta 1";
  EXPECT_THROW(read_log(p, c), InvalidArgument);
  c = pendulum_columns();
  c.state[1].of = "phi";
  EXPECT_THROW(read_log(p, c), InvalidArgument);
  c = pendulum_columns();
  c.action = {"theta"};
  EXPECT_THROW(read_log(p, c), InvalidArgument);
  c = pendulum_columns(true);
  c.state[1].name = "";
  std::string why;
  EXPECT_FALSE(c.IsValid(&why));
  EXPECT_NE(why.find("a derived velocity needs a name"), std::string::npos) << why;
  LogOptions o;
  o.dt = 0;
  EXPECT_THROW(read_log(p, pendulum_columns(), o), InvalidArgument);
  o = {};
  o.lowpass_hz = 60;  // above the 100 Hz log's grid Nyquist (50 Hz)
  EXPECT_THROW(read_log(p, pendulum_columns(), o), InvalidArgument);
}

// ---- a real robot's log ----

// The DFKI Underactuated Lab's double pendulum (README beside it): 10 s at about 500 Hz, both
// joints driven. CI finds it in the shared/ folder beside the repository; skipped without it.
TEST(RecordedLog, RealDoublePendulumLogResamplesToAThousandTransitionsAndItsVelocitiesAgree) {
  const fs::path p = fs::path(DROPS_SOURCE_DIR) / ".." / "shared" / "data" /
                     "double-pendulum-dfki" / "sys_id" / "trajectory_00.csv";
  if (!fs::exists(p)) GTEST_SKIP() << p << " is absent";
  LogColumns logged;
  logged.state = {{"pos_meas1", LogQuantity::kAngle, "", "q1"},
                  {"pos_meas2", LogQuantity::kAngle, "", "q2"},
                  {"vel_meas1", LogQuantity::kVelocity, "q1", "dq1"},
                  {"vel_meas2", LogQuantity::kVelocity, "q2", "dq2"}};
  logged.action = {"tau_meas1", "tau_meas2"};
  LogOptions o;
  o.dt = 0.01;
  const RecordedLog log = read_log(p, logged, o);
  EXPECT_EQ(log.report.rows, 4997);
  EXPECT_EQ(log.report.gaps, 0);
  EXPECT_EQ(log.segments.size(), 1u);
  EXPECT_EQ(log.report.transitions, 999);  // 9.9999 s
  EXPECT_NEAR(log.report.median_interval, 0.002, 1e-5);
  EXPECT_EQ(log.report.angle_wraps, (std::vector<int>{0, 0, 0, 0}));
  const LogTable raw = parse_log_csv(
      std::string(std::istreambuf_iterator<char>(std::ifstream(p).rdbuf()), {}), p.string(), {});
  for (int e = 0; e < 2; ++e) {
    const Eigen::VectorXd q = raw.values.col(raw.column(logged.state[e].column));
    EXPECT_GE(log.segments[0].x.col(e).minCoeff(), q.minCoeff());
    EXPECT_LE(log.segments[0].x.col(e).maxCoeff(), q.maxCoeff());
  }
  // The drivers' velocities against the smoothed derivative of the angles (derivative_window
  // 0.01 s: 7 points of 2 ms), both on the 2 ms grid: slopes measured 0.9978 and 1.0011, RMS
  // differences 0.059 and 0.090 rad/s (3 % and 1.4 % of the velocities' RMS, 1.98 and 6.54).
  const double tolerance[] = {0.08, 0.12};
  for (int e = 2; e < 4; ++e) {
    EXPECT_NEAR(log.report.velocity_slope[e], 1.0, 0.01) << log.state_names[e];
    EXPECT_LT(log.report.velocity_rms_difference[e], tolerance[e - 2]) << log.state_names[e];
  }
  // The velocities derived from the angles, resampled, against the logged ones resampled.
  LogColumns derived = logged;
  derived.state[2].column.clear();
  derived.state[3].column.clear();
  const RecordedLog d = read_log(p, derived, o);
  ASSERT_EQ(d.report.transitions, 999);
  // Measured 0.059 and 0.089 rad/s at the 1,000 states.
  for (int e = 2; e < 4; ++e) {
    const Eigen::VectorXd diff = d.segments[0].x.col(e) - log.segments[0].x.col(e);
    EXPECT_LT(std::sqrt(diff.squaredNorm() / diff.size()), tolerance[e - 2]) << log.state_names[e];
  }
  // The angles and the actions are the same in both.
  EXPECT_EQ(d.segments[0].x.leftCols(2), log.segments[0].x.leftCols(2));
  EXPECT_EQ(d.segments[0].u, log.segments[0].u);
}
