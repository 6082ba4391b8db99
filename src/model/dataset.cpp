#include "drops/model/dataset.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "drops/core/errors.hpp"
#include "drops/core/parallel.hpp"

namespace drops::model {
namespace {
MatrixXd take_rows(const MatrixXd& m, const std::vector<int>& idx) {
  MatrixXd out(static_cast<Eigen::Index>(idx.size()), m.cols());
  for (std::size_t k = 0; k < idx.size(); ++k) out.row(static_cast<Eigen::Index>(k)) = m.row(idx[k]);
  return out;
}
}  // namespace

Dataset Dataset::rows(const std::vector<int>& idx) const {
  Dataset d{take_rows(x, idx), take_rows(u, idx), take_rows(dx, idx), take_rows(gp_in, idx), {}};
  bool every_row = static_cast<int>(idx.size()) == size();
  for (std::size_t k = 0; every_row && k < idx.size(); ++k) every_row = idx[k] == static_cast<int>(k);
  if (every_row) d.pairs = pairs;
  return d;
}

Dataset make_dataset(const std::vector<Transition>& data, const Task* task, int E, int U) {
  Dataset d;
  const int N = static_cast<int>(data.size());
  d.x.resize(N, E);
  d.u.resize(N, U);
  d.dx.resize(N, E);
  const int O = task ? task->observation_dim() : 0;
  d.gp_in.resize(N, task ? O + U : 0);
  for (int n = 0; n < N; ++n) {
    const Transition& t = data[static_cast<std::size_t>(n)];
    check_size("transition x", E, t.x.size());
    check_size("transition u", U, t.u.size());
    check_size("transition dx", E, t.dx.size());
    if (!t.x.allFinite() || !t.u.allFinite() || !t.dx.allFinite())
      throw InvalidArgument("transition " + std::to_string(n) + " has non-finite values");
    d.x.row(n) = t.x.transpose();
    d.u.row(n) = t.u.transpose();
    d.dx.row(n) = t.dx.transpose();
  }
  if (task) {
    MatrixXd obs;
    task->observe_batch(d.x, obs);  // one call for every transition
    d.gp_in.leftCols(O) = obs;
    d.gp_in.rightCols(U) = d.u;
  }
  return d;
}

std::vector<int> subsample(int N, int max_points) {
  std::vector<int> idx;
  if (max_points <= 0 || N <= max_points) {
    for (int i = 0; i < N; ++i) idx.push_back(i);
    return idx;
  }
  for (int k = 0; k < max_points; ++k)
    idx.push_back(static_cast<int>(std::floor(static_cast<double>(k) * N / max_points)));
  return idx;
}

MatrixXd prior_outputs(const MeanFunction& prior, const MatrixXd& X, const MatrixXd& U,
                       const VectorXd& phi, long* nonfinite) {
  const int N = static_cast<int>(X.rows()), E = prior.state_dim();
  MatrixXd out(N, E);
  constexpr int kChunk = 64;
  const int chunks = (N + kChunk - 1) / kChunk;
  std::vector<long> bad(static_cast<std::size_t>(chunks), 0);
  parallel_for(static_cast<std::size_t>(chunks), [&](std::size_t c) {
    const int begin = static_cast<int>(c) * kChunk;
    const int rows = std::min(N, begin + kChunk) - begin;
    MatrixXd dX;
    prior.evaluate_batch(X.middleRows(begin, rows), U.middleRows(begin, rows), phi, dX);
    for (int k = 0; k < rows; ++k)
      if (!dX.row(k).allFinite()) ++bad[c];
    out.middleRows(begin, rows) = dX;
  });
  long total = 0;
  for (long b : bad) total += b;
  if (nonfinite) *nonfinite += total;
  return out;
}

}  // namespace drops::model
