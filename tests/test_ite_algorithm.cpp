// IT&E as a drops algorithm (algo::Ite, algorithm=ite) on the pendubot with tiny archive budgets:
// the same archive and trials with 1 and 2 threads; one trial when the real system is the prior;
// resumed runs (after an episode, and in the middle of the archive's generation, through the run
// directory) equal uninterrupted ones; the archive file round trip through the run directory and
// ite.archive; the archive cache; the errors for a task without a descriptor and a bad archive.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "drops/algo/ite.hpp"
#include "drops/core/errors.hpp"
#include "drops/core/parallel.hpp"
#include "drops/experiment/archive_file.hpp"
#include "drops/experiment/experiment.hpp"
#include "drops/experiment/run_directory.hpp"
#include "drops/pendubot/ite_descriptor.hpp"
#include "fixtures.hpp"

namespace {

using namespace drops;
namespace fs = std::filesystem;

// A small IT&E experiment on the pendubot: 3 bins per dimension (729 cells), 1,500 evaluations.
const std::vector<std::string> kTiny = {"algorithm=ite",       "ite.evaluations=1500",
                                        "ite.batch=100",       "ite.initial_population=100",
                                        "ite.bins=3",          "episodes=4"};

experiment::Experiment make(const std::vector<std::string>& more = {}) {
  std::vector<std::string> ov = kTiny;
  ov.insert(ov.end(), more.begin(), more.end());
  return fixtures::experiment(ov);
}

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// What a run handed out: its episodes, its last state and the last archive.
struct Outcome {
  std::vector<algo::EpisodeRecord> records;
  std::vector<algo::RunState> states;
  algo::ArchiveState archive;
  algo::RunSummary summary;
};

// Runs e (threads, optional resume) and stops when stop_when(outcome, status) says so.
Outcome run(const experiment::Experiment& e, int threads, const algo::RunState* resume = nullptr,
            std::function<bool(const Outcome&, const algo::Status&)> stop_when = {}) {
  ThreadLimit limit(threads);
  Outcome out;
  algo::Status last;
  algo::Callbacks cb;
  cb.on_episode = [&](const algo::EpisodeRecord& r) { out.records.push_back(r); };
  cb.on_state = [&](const algo::RunState& s) {
    out.states.push_back(s);
    if (const auto* a = algo::archive_state(s)) out.archive = *a;
  };
  cb.on_status = [&](const algo::Status& s) { last = s; };
  cb.should_stop = [&] { return stop_when && stop_when(out, last); };
  out.summary = e.runner->run(e.setup.problem(), cb, resume);
  return out;
}

void expect_same_episodes(const std::vector<algo::EpisodeRecord>& a,
                          const std::vector<algo::EpisodeRecord>& b, std::size_t from_b = 0) {
  ASSERT_EQ(a.size(), b.size() + from_b);
  for (std::size_t i = 0; i < b.size(); ++i) {
    const auto& x = a[i + from_b];
    const auto& y = b[i];
    EXPECT_EQ(x.episode, y.episode);
    EXPECT_EQ(x.theta, y.theta) << "episode " << y.episode;
    EXPECT_EQ(x.real_return, y.real_return) << "episode " << y.episode;
    EXPECT_EQ(x.predicted_return, y.predicted_return) << "episode " << y.episode;
    EXPECT_EQ(x.details.numbers, y.details.numbers) << "episode " << y.episode;
  }
}

class TempDir {
 public:
  TempDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = fs::temp_directory_path() /
            (std::string("drops-test-ite-") + info->name() + "-" + std::to_string(::getpid()));
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() { fs::remove_all(path_); }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

TEST(IteAlgorithm, ThePendubotPluginDescribesEpisodesByTheTipOfThePriorsLengths) {
  const auto e = make({"prior.preset=tunable-misleading"});  // l2 = 0.25 in the prior
  ASSERT_NE(experiment::task_behaviour(e.setup), nullptr);
  const auto& b = *experiment::task_behaviour(e.setup);
  ASSERT_TRUE(b.available());
  EXPECT_EQ(b.bins, std::vector<int>(6, 5));
  EXPECT_EQ(b.names.size(), 6u);
  const rollout::Trajectory tr =
      algo::prior_episode(e.setup.problem(), VectorXd::Constant(81, 0.3));
  EXPECT_EQ(b.describe(tr), pendubot::tip_descriptor(tr, 0.5, 0.25));
  const auto o = experiment::ite_options(e.settings, e.setup);
  EXPECT_EQ(o.bins, std::vector<int>(6, 3));  // ite.bins overrides the task's grid
}

TEST(IteAlgorithm, SameSeedGivesTheSameArchiveAndTrialsWithOneAndTwoThreads) {
  const auto e = make({"ite.stop_ratio=0"});  // 4 trials, no early stop
  const Outcome one = run(e, 1);
  const Outcome two = run(e, 2);
  ASSERT_TRUE(one.archive.archive && two.archive.archive);
  EXPECT_TRUE(*one.archive.archive == *two.archive.archive);
  EXPECT_GT(one.archive.archive->size(), 20u);
  EXPECT_TRUE(algo::archive_state(one.states.back())->complete);
  EXPECT_EQ(algo::archive_state(one.states.back())->cursor.evaluations, 1500);  // every state says it
  expect_same_episodes(one.records, two.records);
  ASSERT_EQ(one.records.size(), 4u);
  // Trials are cells of the archive; the first is its best.
  EXPECT_EQ(one.records[0].theta, one.archive.archive->best().theta);
  for (const auto& r : one.records) EXPECT_EQ(r.selected, "trial");
  // Another seed, another archive.
  const Outcome other = run(make({"ite.stop_ratio=0", "seed=2"}), 2);
  EXPECT_FALSE(*other.archive.archive == *one.archive.archive);
}

TEST(IteAlgorithm, WhenTheRealSystemIsThePriorAdaptationStopsAfterOneTrial) {
  const auto end = run(make({"prior.preset=actual", "ite.after_stop=end"}), 2);
  ASSERT_EQ(end.records.size(), 1u);
  const auto& best = end.archive.archive->best();
  EXPECT_EQ(end.records[0].theta, best.theta);
  EXPECT_NEAR(end.records[0].real_return, best.fitness, 1e-9 * (1 + std::abs(best.fitness)));
  EXPECT_EQ(end.summary.details.numbers.at("trials"), 1.0);
  EXPECT_EQ(end.summary.details.numbers.at("stopped_by_rule"), 1.0);
  EXPECT_EQ(end.records[0].details.numbers.at("stop"), 1.0);
  // repeat_best: the remaining episodes run the best tested cell again.
  const auto repeat = run(make({"prior.preset=actual"}), 2);
  ASSERT_EQ(repeat.records.size(), 4u);
  EXPECT_EQ(repeat.summary.details.numbers.at("trials"), 1.0);
  for (std::size_t i = 1; i < 4; ++i) {
    EXPECT_EQ(repeat.records[i].selected, "best_tested");
    EXPECT_EQ(repeat.records[i].details.numbers.at("trial"), 0.0);
    EXPECT_EQ(repeat.records[i].theta, best.theta);
    EXPECT_EQ(repeat.records[i].real_return, repeat.records[0].real_return);
  }
  // A prior that differs from the real system: more than one trial is needed here.
  const auto gap = run(make({"prior.preset=tunable-misleading", "ite.after_stop=end"}), 2);
  EXPECT_GT(gap.records.size(), 1u);
}

// ite.observation_floor: M-BOA observes max(floor, performance). With a floor above every return
// of the pendubot (returns are in [0, 50]), trial 1's cell is observed at the floor, far above the
// archive's fitness elsewhere, so UCB picks it again in every trial; without the floor the
// misleading prior's trials move on (as in the test above). The recorded returns are the real ones.
TEST(IteAlgorithm, AnObservationFloorIsWhatMboaSeesNotWhatIsRecorded) {
  const std::vector<std::string> gap = {"prior.preset=tunable-misleading", "ite.stop_ratio=0"};
  const auto plain = run(make(gap), 2);
  std::vector<std::string> floored = gap;
  floored.push_back("ite.observation_floor=1000");
  const auto high = run(make(floored), 2);
  ASSERT_EQ(plain.records.size(), 4u);
  ASSERT_EQ(high.records.size(), 4u);
  EXPECT_EQ(plain.records[0].theta, high.records[0].theta);  // the first pick: the archive's best
  EXPECT_EQ(plain.records[0].real_return, high.records[0].real_return);
  EXPECT_LT(high.records[0].real_return, 1000.0);
  bool plain_moved = false;
  for (std::size_t i = 1; i < 4; ++i) {
    EXPECT_EQ(high.records[i].theta, high.records[0].theta) << "trial " << i + 1;
    EXPECT_EQ(high.records[i].real_return, high.records[0].real_return);
    plain_moved = plain_moved || plain.records[i].theta != plain.records[0].theta;
  }
  EXPECT_TRUE(plain_moved);
  // A floor below every return changes nothing.
  std::vector<std::string> low = gap;
  low.push_back("ite.observation_floor=-1");
  const auto same = run(make(low), 2);
  ASSERT_EQ(same.records.size(), 4u);
  for (std::size_t i = 0; i < 4; ++i) EXPECT_EQ(same.records[i].theta, plain.records[i].theta);
}

TEST(IteAlgorithm, AResumedRunGivesTheTrialsOfAnUninterruptedOne) {
  const auto e = make({"ite.stop_ratio=0"});
  const Outcome whole = run(e, 2);
  // Stopped before episode 3: the state after episode 2 continues it.
  const Outcome first = run(e, 2, nullptr, [](const Outcome& o, const algo::Status&) {
    return o.records.size() == 2;
  });
  EXPECT_TRUE(first.summary.interrupted);
  ASSERT_EQ(first.records.size(), 2u);
  const algo::RunState state = first.states.back();
  EXPECT_EQ(state.episodes_done, 2);
  EXPECT_EQ(algo::IteTrials::load(state.extra).cells.size(), 2u);
  const Outcome rest = run(e, 1, &state);
  expect_same_episodes(whole.records, rest.records, 2);
  EXPECT_EQ(rest.summary.details.numbers.at("trials"), 4.0);
}

TEST(IteAlgorithm, AnArchiveGenerationInterruptedAndResumedThroughTheRunDirectoryEqualsAWholeRun) {
  TempDir tmp;
  const auto e = make({"ite.stop_ratio=0", "ite.checkpoint_minutes=0"});
  const Outcome whole = run(e, 2);
  const fs::path dir = tmp.path() / "run";
  {
    experiment::RunDirectory rd(dir, experiment::to_yaml(fixtures::registry(), e.settings), e);
    ThreadLimit limit(2);
    algo::Callbacks cb;
    long evaluations = 0;
    cb.on_status = [&](const algo::Status& s) { evaluations = s.evaluations; };
    cb.should_stop = [&] { return evaluations >= 700; };  // in the middle of MAP-Elites
    cb.on_state = [&](const algo::RunState& s) { rd.save_state(s); };
    cb.on_episode = [&](const algo::EpisodeRecord& r) { rd.record(r); };
    const auto s = e.runner->run(e.setup.problem(), cb);
    EXPECT_TRUE(s.interrupted);
    EXPECT_EQ(s.episodes_done, 0);
    rd.finish(s, "interrupted");
  }
  ASSERT_TRUE(fs::exists(dir / "archive.csv"));
  ASSERT_TRUE(fs::exists(dir / "checkpoint.json"));
  EXPECT_FALSE(experiment::read_archive_file(dir / "archive.csv").info.complete);
  algo::RunState state;
  auto rd = experiment::RunDirectory::reopen(
      dir, e, experiment::to_yaml(fixtures::registry(), e.settings), &state);
  EXPECT_EQ(state.episodes_done, 0);
  ASSERT_TRUE(algo::archive_state(state) && algo::archive_state(state)->archive);
  EXPECT_FALSE(algo::archive_state(state)->complete);
  EXPECT_EQ(algo::archive_state(state)->cursor.evaluations, 700);
  algo::Callbacks cb;
  std::vector<algo::EpisodeRecord> records;
  cb.on_state = [&](const algo::RunState& s) { rd->save_state(s); };
  cb.on_episode = [&](const algo::EpisodeRecord& r) {
    rd->record(r);
    records.push_back(r);
  };
  const auto s = e.runner->run(e.setup.problem(), cb, &state);
  rd->finish(s, "complete");
  expect_same_episodes(whole.records, records);
  const auto file = experiment::read_archive_file(dir / "archive.csv");
  EXPECT_TRUE(file.info.complete);
  EXPECT_TRUE(*file.archive == *whole.archive.archive);
  EXPECT_EQ(file.info.task, "pendubot");
  EXPECT_EQ(file.info.descriptor_names, experiment::task_behaviour(e.setup)->names);
  EXPECT_EQ(file.info.cursor.evaluations, 1500);

  // ite.archive: a run adapting with the saved archive makes the same trials, without MAP-Elites.
  const auto loaded = make({"ite.stop_ratio=0", "ite.archive=" + (dir / "archive.csv").string()});
  const Outcome again = run(loaded, 2);
  expect_same_episodes(whole.records, again.records);
  EXPECT_EQ(again.summary.details.numbers.count("archive_evaluations"), 0u);
  EXPECT_EQ(again.records[0].evaluations, 0);
  EXPECT_TRUE(*again.archive.archive == *whole.archive.archive);
  // The given archive keeps its file's MAP-Elites cursor (what summary.json reports of it).
  EXPECT_EQ(again.archive.cursor.evaluations, 1500);
}

// --resume of a run stopped in its archive's generation: a damaged archive.csv, or none beside a
// checkpoint that covers no episode, is refused naming the file, and nothing is changed.
TEST(IteAlgorithm, AResumeWithADamagedOrMissingArchiveIsRefusedNamingTheFile) {
  TempDir tmp;
  const auto e = make({"ite.checkpoint_minutes=0"});
  const std::string yaml = experiment::to_yaml(fixtures::registry(), e.settings);
  const fs::path dir = tmp.path() / "run";
  {
    experiment::RunDirectory rd(dir, yaml, e);
    algo::Callbacks cb;
    long evaluations = 0;
    cb.on_status = [&](const algo::Status& s) { evaluations = s.evaluations; };
    cb.should_stop = [&] { return evaluations >= 700; };
    cb.on_state = [&](const algo::RunState& s) { rd.save_state(s); };
    const auto s = e.runner->run(e.setup.problem(), cb);
    ASSERT_EQ(s.episodes_done, 0);
    rd.finish(s, "interrupted");
  }
  const fs::path archive = dir / "archive.csv";
  const std::string good = read_text(archive);
  auto refusal = [&] {
    algo::RunState state;
    try {
      experiment::RunDirectory::reopen(dir, e, yaml, &state);
    } catch (const experiment::RunDirectoryDamaged& ex) {
      return std::string(ex.what());
    }
    return std::string("not refused");
  };
  std::ofstream(archive, std::ios::app) << "1,2,oops\n";
  EXPECT_NE(refusal().find(archive.string()), std::string::npos) << refusal();
  EXPECT_EQ(read_text(archive), good + "1,2,oops\n");
  fs::remove(archive);
  EXPECT_NE(refusal().find("archive.csv is missing"), std::string::npos) << refusal();
  std::ofstream(archive) << good;
  algo::RunState state;
  EXPECT_NO_THROW(experiment::RunDirectory::reopen(dir, e, yaml, &state));
  EXPECT_EQ(algo::archive_state(state)->cursor.evaluations, 700);
}

TEST(IteAlgorithm, TheArchiveCacheIsSharedByRunsThatDifferOnlyInTheRealSystem) {
  TempDir tmp;
  const std::string cache = "ite.archive_cache=" + (tmp.path() / "cache").string();
  const Outcome first = run(make({cache}), 2);
  ASSERT_EQ(std::distance(fs::directory_iterator(tmp.path() / "cache"), fs::directory_iterator{}),
            1);
  EXPECT_GT(first.summary.details.numbers.at("archive_evaluations"), 0.0);
  // Another real system (its own keys) and another adaptation: the cached archive, no MAP-Elites.
  const Outcome second = run(make({cache, "system.m2=0.6", "ite.kappa=0.2"}), 2);
  EXPECT_EQ(second.summary.details.numbers.count("archive_evaluations"), 0u);
  EXPECT_TRUE(*second.archive.archive == *first.archive.archive);
  EXPECT_EQ(second.archive.cursor.evaluations, first.archive.cursor.evaluations);
  // Another seed or prior: another archive.
  run(make({cache, "seed=5"}), 2);
  run(make({cache, "prior.preset=tunable"}), 2);
  EXPECT_EQ(std::distance(fs::directory_iterator(tmp.path() / "cache"), fs::directory_iterator{}),
            3);
}

TEST(IteAlgorithm, ATasksEntryOfAnotherTypeIsAnErrorNotAMissingDescriptor) {
  experiment::TaskSetup setup;
  EXPECT_EQ(experiment::task_behaviour(setup), nullptr);
  setup.algorithm_data.set("ite", 3);  // a task that disagrees with IT&E on the entry's type
  EXPECT_THROW(experiment::task_behaviour(setup), Error);
  ite::BehaviourDescriptor b;
  b.names = {"x"};
  setup.algorithm_data.set("ite", b);
  ASSERT_NE(experiment::task_behaviour(setup), nullptr);
  EXPECT_EQ(experiment::task_behaviour(setup)->names, b.names);
  setup.algorithm_data.erase("ite");
  EXPECT_EQ(experiment::task_behaviour(setup), nullptr);
}

// A task that offers no behaviour descriptor: the pendubot without it.
class NoDescriptorTask final : public experiment::TaskPlugin {
 public:
  std::string name() const override { return "blind"; }
  std::string description() const override { return "the pendubot without a descriptor"; }
  std::vector<experiment::KeySpec> keys() const override { return {}; }
  experiment::TaskSetup make(const experiment::Settings& s) const override {
    experiment::Settings p = s;
    p["task"] = "pendubot";
    experiment::TaskSetup setup =
        fixtures::registry().task("pendubot").make(fixtures::settings("", {"task=pendubot"}));
    setup.algorithm_data.erase("ite");
    return setup;
  }
  std::string prior_label(const experiment::Settings&) const override { return "p"; }
  experiment::ReportInfo report_info(const experiment::Settings&) const override { return {}; }
};

TEST(IteAlgorithm, ATaskWithoutADescriptorOrABadArchiveIsAConfigErrorNamingIt) {
  experiment::Registry registry;
  experiment::register_builtin_algorithms(registry);
  registry.add_task(std::make_unique<NoDescriptorTask>());
  try {
    experiment::make_experiment(registry,
                                experiment::load_settings(registry, "", {"algorithm=ite"}));
    FAIL() << "expected a ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("'blind' has no behaviour descriptor"), std::string::npos)
        << e.what();
  }
  TempDir tmp;
  const fs::path missing = tmp.path() / "none.csv";
  EXPECT_THROW(make({"ite.archive=" + missing.string()}), ConfigError);
  // An archive of other policies (a network of 5 hidden units: 41 parameters).
  const auto small = make({"policy.hidden_units=5", "episodes=1"});
  const Outcome o = run(small, 2);
  const fs::path file = tmp.path() / "small.csv";
  experiment::write_archive_file(file, *o.archive.archive,
                                 experiment::archive_file_info("pendubot", small.setup));
  try {
    make({"ite.archive=" + file.string()});
    FAIL() << "expected a ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("config key 'ite.archive'"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("41 parameters"), std::string::npos) << e.what();
  }
  EXPECT_NO_THROW(make({"policy.hidden_units=5", "ite.archive=" + file.string()}));
}

}  // namespace

// IT&E's own state reads back what it wrote, and refuses entries that are missing, of unequal
// length or not cell indices (a checkpoint edited by hand), naming the entry.
TEST(IteAlgorithm, ItsTrialsReadBackExactlyAndMalformedOnesAreRefused) {
  algo::IteTrials t;
  t.cells = {0, 41, 7};
  t.returns = {0.1, -2.5, 1.0 / 3.0};
  const algo::IteTrials back = algo::IteTrials::load(t.save());
  EXPECT_EQ(back.cells, t.cells);
  EXPECT_EQ(back.returns, t.returns);
  auto refused = [](algo::StateVectors v, const std::string& why) {
    try {
      algo::IteTrials::load(v);
      ADD_FAILURE() << "accepted; expected: " << why;
    } catch (const InvalidArgument& e) {
      EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
    }
  };
  refused({}, "no IT&E trials");
  algo::StateVectors v = t.save();
  v.begin()->second.conservativeResize(2);
  refused(v, "no IT&E trials");
  v = t.save();
  for (auto& [k, x] : v)
    if (k.find("cells") != std::string::npos) x[1] = 2.5;
  refused(v, "not a cell index");
}
