// Exact moments of sums of sines of a Gaussian vector (gTrig, gSat, gSin of PILCO; baselines.md
// §1a), from E[cos(h^T x + psi)] = exp(-1/2 h^T Sigma h) cos(h^T mu + psi).
#include "drops/pilco/trig.hpp"

#include <cmath>
#include <numbers>
#include <string>

#include "detail.hpp"
#include "drops/core/errors.hpp"

namespace drops::pilco {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

namespace {

constexpr double kHalfPi = std::numbers::pi / 2.0;

// E[cos(h^T x + psi)] and its derivatives: d/dmu = -E[sin(.)] h, d/dSigma = -1/2 E[cos(.)] h h^T.
struct CosExpectation {
  double value = 0.0;
  double sin_value = 0.0;  // E[sin(h^T x + psi)]
};

CosExpectation cos_expectation(const VectorXd& h, double psi, const VectorXd& mu,
                               const MatrixXd& sigma) {
  const double damp = std::exp(-0.5 * h.dot(sigma * h));
  const double arg = h.dot(mu) + psi;
  return {damp * std::cos(arg), damp * std::sin(arg)};
}

// Adds w * d E[cos(h^T x + psi)] / d(mu, Sigma) to row `row` of (dmu, dsigma).
void add_cos_derivative(double w, const VectorXd& h, const CosExpectation& e, Index row,
                        MatrixXd& dmu, MatrixXd& dsigma) {
  dmu.row(row) -= (w * e.sin_value) * h.transpose();
  const MatrixXd hh = h * h.transpose();
  dsigma.row(row) -= (0.5 * w * e.value) * detail::as_row(hh);
}

}  // namespace

Moments sine_moments(const std::vector<SineFeature>& features, const VectorXd& mu,
                     const MatrixXd& sigma, bool derivatives) {
  const Index D = mu.size();
  detail::check_gaussian("sine_moments", D, mu, sigma);
  const Index E = static_cast<Index>(features.size());
  for (Index o = 0; o < E; ++o) {
    for (const SineTerm& t : features[o].terms) {
      check_size(("sine_moments: direction of a term of feature " + std::to_string(o)).c_str(), D,
                 t.direction.size());
    }
  }
  Moments m;
  m.mean = VectorXd::Zero(E);
  m.cov = MatrixXd::Zero(E, E);
  m.cross = MatrixXd::Zero(D, E);
  if (derivatives) {
    m.dmean_dmu = MatrixXd::Zero(E, D);
    m.dmean_dsigma = MatrixXd::Zero(E, D * D);
    m.dcov_dmu = MatrixXd::Zero(E * E, D);
    m.dcov_dsigma = MatrixXd::Zero(E * E, D * D);
    m.dcross_dmu = MatrixXd::Zero(D * E, D);
    m.dcross_dsigma = MatrixXd::Zero(D * E, D * D);
  }
  for (Index o = 0; o < E; ++o) {
    for (const SineTerm& t : features[o].terms) {
      // E[sin(g^T x + phi)] = E[cos(g^T x + phi - pi/2)]; E[dy/dx] = sum a g E[cos(g^T x + phi)].
      const CosExpectation es = cos_expectation(t.direction, t.phase - kHalfPi, mu, sigma);
      const CosExpectation ec = cos_expectation(t.direction, t.phase, mu, sigma);
      m.mean[o] += t.amplitude * es.value;
      m.cross.col(o) += (t.amplitude * ec.value) * t.direction;
      if (derivatives) {
        add_cos_derivative(t.amplitude, t.direction, es, o, m.dmean_dmu, m.dmean_dsigma);
        for (Index k = 0; k < D; ++k) {
          if (t.direction[k] == 0.0) continue;
          add_cos_derivative(t.amplitude * t.direction[k], t.direction, ec, k + D * o, m.dcross_dmu,
                             m.dcross_dsigma);
        }
      }
    }
  }
  // Second moments: sin a sin b = (cos(a - b) - cos(a + b)) / 2.
  for (Index o = 0; o < E; ++o) {
    for (Index p = o; p < E; ++p) {
      double second = 0.0;
      MatrixXd dmu = MatrixXd::Zero(derivatives ? 1 : 0, D);
      MatrixXd dsig = MatrixXd::Zero(derivatives ? 1 : 0, D * D);
      for (const SineTerm& t : features[o].terms) {
        for (const SineTerm& s : features[p].terms) {
          const double w = 0.5 * t.amplitude * s.amplitude;
          const VectorXd hm = t.direction - s.direction;
          const VectorXd hp = t.direction + s.direction;
          const CosExpectation em = cos_expectation(hm, t.phase - s.phase, mu, sigma);
          const CosExpectation ep = cos_expectation(hp, t.phase + s.phase, mu, sigma);
          second += w * (em.value - ep.value);
          if (derivatives) {
            add_cos_derivative(w, hm, em, 0, dmu, dsig);
            add_cos_derivative(-w, hp, ep, 0, dmu, dsig);
          }
        }
      }
      const double c = second - m.mean[o] * m.mean[p];
      m.cov(o, p) = c;
      m.cov(p, o) = c;
      if (derivatives) {
        dmu -= m.mean[p] * m.dmean_dmu.row(o) + m.mean[o] * m.dmean_dmu.row(p);
        dsig -= m.mean[p] * m.dmean_dsigma.row(o) + m.mean[o] * m.dmean_dsigma.row(p);
        m.dcov_dmu.row(o + E * p) = dmu;
        m.dcov_dmu.row(p + E * o) = dmu;
        m.dcov_dsigma.row(o + E * p) = dsig;
        m.dcov_dsigma.row(p + E * o) = dsig;
      }
    }
  }
  return m;
}

Moments trig_moments(const std::vector<int>& angles, const VectorXd& mu, const MatrixXd& sigma,
                     bool derivatives) {
  const Index D = mu.size();
  std::vector<SineFeature> features;
  for (int i : angles) {
    if (i < 0 || i >= D) {
      throw InvalidArgument("trig_moments: angle index: expected in [0, " + std::to_string(D) +
                            "), got " + std::to_string(i));
    }
    const VectorXd e = VectorXd::Unit(D, i);
    features.push_back(SineFeature{{SineTerm{e, 0.0, 1.0}}});      // sin x_i
    features.push_back(SineFeature{{SineTerm{e, kHalfPi, 1.0}}});  // cos x_i = sin(x_i + pi/2)
  }
  return sine_moments(features, mu, sigma, derivatives);
}

Moments squash_moments(const VectorXd& max_u, const VectorXd& mu, const MatrixXd& sigma,
                       bool derivatives) {
  const Index U = max_u.size();
  check_size("squash_moments: mean (one per control bound)", U, mu.size());
  if (!(max_u.array() > 0.0).all() || !max_u.allFinite()) {
    throw InvalidArgument("squash_moments: max_u: expected finite values > 0");
  }
  std::vector<SineFeature> features;
  for (Index k = 0; k < U; ++k) {
    const VectorXd e = VectorXd::Unit(U, k);
    features.push_back(SineFeature{
        {SineTerm{e, 0.0, 9.0 / 8.0 * max_u[k]}, SineTerm{3.0 * e, 0.0, 1.0 / 8.0 * max_u[k]}}});
  }
  return sine_moments(features, mu, sigma, derivatives);
}

double squash(double x, double max_u) {
  return max_u * (9.0 * std::sin(x) + std::sin(3.0 * x)) / 8.0;
}

}  // namespace drops::pilco
