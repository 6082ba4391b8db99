// Neural-network policy (settings.md §2) against a naive evaluation.
#include <gtest/gtest.h>

#include <cmath>

#include "drops/core/errors.hpp"
#include "drops/core/rng.hpp"
#include "drops/policy/policy.hpp"

using namespace drops;

TEST(NeuralNetPolicy, HasEightyOneParametersForThePendubot) {
  policy::NeuralNetPolicy p;
  EXPECT_EQ(p.param_dim(), 81);
}

TEST(NeuralNetPolicy, MatchesANaiveForwardPass) {
  policy::NeuralNetPolicyOptions o;
  o.input_scale = VectorXd(6);
  o.input_scale << 10, 10, 1, 1, 1, 1;
  policy::NeuralNetPolicy p(o);
  Rng rng(5);
  VectorXd theta(81);
  for (int i = 0; i < 81; ++i) theta[i] = rng.uniform(-1, 1);
  p.set_params(theta);
  VectorXd obs(6), u(1);
  for (int i = 0; i < 6; ++i) obs[i] = rng.uniform(-3, 3);
  p.act(obs, 0.0, u);
  // naive: W1 is 10 x 7 row-major, then W2 1 x 11
  double out = theta[70 + 10];
  for (int j = 0; j < 10; ++j) {
    double a = theta[j * 7 + 6];
    for (int i = 0; i < 6; ++i) a += theta[j * 7 + i] * obs[i] / o.input_scale[i];
    out += theta[70 + j] * std::tanh(5 * a);
  }
  EXPECT_NEAR(u[0], 3.5 * std::tanh(5 * out), 1e-12);
}

TEST(NeuralNetPolicy, OutputIsBounded) {
  policy::NeuralNetPolicy p;
  p.set_params(VectorXd::Constant(81, 5.0));
  VectorXd obs = VectorXd::Constant(6, 100.0), u(1);
  p.act(obs, 0.0, u);
  EXPECT_LE(std::abs(u[0]), 3.5);
  EXPECT_GT(std::abs(u[0]), 3.4);
}

TEST(NeuralNetPolicy, RejectsWrongSizesAndNaN) {
  policy::NeuralNetPolicy p;
  EXPECT_THROW(p.set_params(VectorXd::Zero(80)), InvalidArgument);
  VectorXd t = VectorXd::Zero(81);
  t[3] = std::nan("");
  EXPECT_THROW(p.set_params(t), InvalidArgument);
  policy::NeuralNetPolicyOptions bad;
  bad.hidden_units = 0;
  EXPECT_THROW(policy::NeuralNetPolicy{bad}, InvalidArgument);
}
