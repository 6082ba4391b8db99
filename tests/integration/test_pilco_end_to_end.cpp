// PILCO learns a single-pendulum swing-up (tests/pendulum_task.hpp) end to end with a fixed seed
// (slow; label "slow"). Measured (seed 1, 10 episodes): solved from episode 2 on, returns
// 19.42 .. 21.83 of 40, 107 s on 2 busy cores; 5 episodes keep it short.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>

#include "../pendulum_task.hpp"
#include "drops/algo/pilco.hpp"

TEST(PilcoEndToEnd, LearnsThePendulumSwingUp) {
  drops::algo::PilcoOptions o;
  o.episodes = 5;
  o.seed = 1;
  o.centres = 50;
  std::vector<drops::algo::EpisodeRecord> eps;
  drops::algo::Callbacks cb;
  cb.on_episode = [&](const drops::algo::EpisodeRecord& e) {
    eps.push_back(e);
    std::printf(
        "episode %d: return %.2f predicted %.2f solved %d (model %.1f s, policy %.1f s, %ld "
        "evaluations)\n",
        e.episode, e.real_return, e.predicted_return, e.solved ? 1 : 0, e.model_seconds,
        e.policy_seconds, e.evaluations);
    std::fflush(stdout);
  };
  const drops::testing::PendulumSystem real;
  const auto s = drops::algo::run_pilco(std::make_shared<drops::testing::PendulumTask>(), real,
                                        nullptr, {}, drops::testing::pendulum_task_model(), o, cb);
  std::printf("%s\n", s.BriefReport().c_str());
  EXPECT_GT(s.first_solved_episode, 0);
  EXPECT_LE(s.first_solved_episode, 3);
  ASSERT_EQ(eps.size(), 5u);
  for (std::size_t k = 2; k < eps.size(); ++k) EXPECT_TRUE(eps[k].solved) << "episode " << k + 1;
}
