#pragma once
/// \file The 36-parameter open-loop periodic gait controller of the hexapod (settings.md §6; the
/// controller of Cully et al., Nature 2015, used by paper §V-B). Pure Eigen, no DART.
///
/// Parameters theta (dim 36, every entry in [0, 1]), leg-major:
///   theta[6 k + 0, 1, 2] = (amplitude, phase, duty) of joint 1 (hip) of leg k,
///   theta[6 k + 3, 4, 5] = (amplitude, phase, duty) shared by joints 2 (femur) and 3 (tibia) of
///                          leg k,   for k = 0..5 (leg numbering of robot.hpp).
///
/// One signal (amplitude a, phase p, duty d) is a periodic sequence of N = 100 samples over the
/// period T = 1 s (sample i covers t in [i T / N, (i + 1) T / N)):
///   1. square wave  w[i] = +a if i < d N, else -a         (so ceil(d N) samples are +a;
///                                                          d = 0: all -a, d = 1: all +a);
///   2. circular smoothing  v[i] = sum_{j=-10..10} g[j] w[(i + j) mod N],
///      g[j] = exp(-j^2 / (2 sigma^2)) / sum_j' exp(-j'^2 / (2 sigma^2)), sigma = 3 samples;
///   3. phase shift (a delay of p periods)  s[i] = v[(i - floor(p N)) mod N].
/// So the rising edge of the square wave is at sample floor(p N) (at time p T); phase 1 = phase 0.
/// Joint targets (rad) at time t: with i = floor(t N / T) mod N (t in s, >= 0),
///   joint 1 = (pi/8) s_hip[i],  joint 2 = (pi/4) s_knee[i],  joint 3 = -(pi/4) s_knee[i].
/// These stay inside the joint limits (pi/2 and pi/4). Output order: 3 k + j (robot.hpp).

#include <Eigen/Core>
#include <array>
#include <string>

namespace drops::hexapod {

/// Options of the periodic signals; defaults are settings.md §6.
struct GaitOptions {
  int samples = 100;    ///< N, samples per period, >= 2
  double period = 1.0;  ///< T, s, > 0
  double sigma = 3.0;   ///< standard deviation of the smoothing kernel, samples, > 0
  int half_width = 10;  ///< kernel taps j = -half_width..half_width, >= 0, < samples
  double hip_scale = 0.39269908169872414;  ///< pi/8: joint 1 = hip_scale * signal, rad
  double knee_scale = 0.7853981633974483;  ///< pi/4: joint 2 = knee_scale * signal = -joint 3
  /// True when every field is in range; otherwise false with the reason in *why (if not null).
  bool IsValid(std::string* why = nullptr) const;
};

/// The normalised Gaussian kernel g[0 .. 2 half_width] (g[half_width] is the centre tap, j = 0).
/// Sums to 1. Throws InvalidArgument when options are invalid. Thread-safe.
Eigen::VectorXd smoothing_kernel(const GaitOptions& options = {});

/// The smoothed, phase-shifted periodic signal s (dim options.samples) for one (amplitude, phase,
/// duty) triple, as defined in the file comment. Throws InvalidArgument when an argument is not in
/// [0, 1] or options are invalid. Thread-safe.
Eigen::VectorXd periodic_signal(double amplitude, double phase, double duty,
                                const GaitOptions& options = {});

/// The open-loop gait controller: the 12 signals are computed once by set_params; targets() is then
/// a table look-up. Copyable; const methods are thread-safe.
/// The tripod gait's parameters (dim 36, in [0, 1], order of the file comment): legs 0, 2, 4 in
/// phase 0 and legs 1, 3, 5 in phase 0.5; duty 0.5; hip amplitude 1, femur/tibia amplitude 0.5.
/// With lift_lag = 0 each foot is lifted (femur signal > 0) while its hip swings forward and pushes
/// on the ground while the hip swings back, so by the sign conventions of robot.hpp the robot walks
/// forward (+x: about 0.28 m/s in the prior, 0.24 m/s on HexapodRealSystem); lift_lag = 0.5 makes
/// it walk backwards. lift_lag in [0, 1). A hand-made reference gait (ours, not the paper's) for
/// tests, benchmarks and as a known walking start. Thread-safe.
Eigen::VectorXd tripod_gait(double lift_lag = 0.0);

class GaitController {
 public:
  /// Number of parameters (36).
  static constexpr int kParamDim = 36;

  /// Throws InvalidArgument when options are invalid. Parameters start at zero (all joints at 0
  /// except that duty 0 gives -amplitude = 0: the robot stands still).
  explicit GaitController(const GaitOptions& options = {});
  /// Sets theta (dim 36, entries in [0, 1], order of the file comment). Throws InvalidArgument on
  /// a wrong size or an entry outside [0, 1] (naming its index) or not finite.
  void set_params(const Eigen::VectorXd& theta);
  /// theta (dim 36).
  const Eigen::VectorXd& params() const { return theta_; }
  /// Target joint angles (rad, dim 18, order 3 k + j) at time t (s, >= 0, finite). A tolerance of
  /// 1e-9 sample absorbs rounding in t = step * dt. Throws InvalidArgument when t is negative or
  /// not finite.
  Eigen::VectorXd targets(double t) const;
  /// Same as targets(t), written into out (dim 18). Throws as targets().
  void targets(double t, Eigen::Ref<Eigen::VectorXd> out) const;
  /// The sample index i used at time t (see the file comment). Throws as targets().
  int sample_index(double t) const;
  /// The hip signal (k, 0) or the shared femur/tibia signal (k, 1) of leg k, dim N, before scaling.
  const Eigen::VectorXd& signal(int leg, int which) const;
  const GaitOptions& options() const { return options_; }

 private:
  GaitOptions options_;
  Eigen::VectorXd theta_;
  std::array<Eigen::VectorXd, 12> signals_;  // 2 k + which
};

}  // namespace drops::hexapod
