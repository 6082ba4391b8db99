// Model variants as registered entries: the four of the paper in one table, a model of one's own
// registered beside them, selected by model.type through the configuration, run by Black-DROPS
// and shown in reports under the label, order and colour it declared.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "drops/core/errors.hpp"
#include "drops/experiment/report.hpp"
#include "drops/experiment/run_directory.hpp"
#include "drops/model/gp_dynamics.hpp"
#include "fixtures.hpp"

using namespace drops;
using namespace drops::experiment;
namespace fs = std::filesystem;

namespace {

std::string read(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

const KeySpec& key_of(const std::vector<KeySpec>& keys, const std::string& key) {
  const auto it =
      std::find_if(keys.begin(), keys.end(), [&](const KeySpec& k) { return k.key == key; });
  if (it == keys.end()) throw InvalidArgument("no key " + key);
  return *it;
}

/// The registry of the drops command line (built-in algorithms, the pendubot) plus the model
/// variant "counting_gp": fixtures::CountingModel around gp_prior, counting into *made and *learns.
std::unique_ptr<Registry> registry_with_own_variant(int* made, int* learns) {
  auto r = std::make_unique<Registry>();
  register_builtin_algorithms(*r);
  pendubot::register_task(*r);
  ModelVariant v;
  v.name = "counting_gp";
  v.description = "gp_prior, counting its learnings";
  v.style = {"GP with priors (counted)", 8, "#e377c2"};
  v.uses_prior = true;
  v.factory = [made, learns](const model::ModelOptions& options,
                             std::shared_ptr<const rollout::Task> task,
                             std::shared_ptr<const model::MeanFunction> prior,
                             const model::PriorParameters& parameters) {
    ++*made;
    model::ModelOptions o = options;
    o.type = model::ModelType::kGpPrior;
    return std::make_unique<fixtures::CountingModel>(
        model::make_model(o, std::move(task), std::move(prior), parameters), learns);
  };
  r->add_model_variant(std::move(v));
  return r;
}

bool matplotlib_available() {
  return std::system("/usr/bin/python3 -c 'import matplotlib, numpy' >/dev/null 2>&1") == 0;
}

}  // namespace

TEST(ModelVariants, ThePapersFourAreRegisteredWithTheirLabelsOrderAndColours) {
  const Registry& r = fixtures::registry();
  EXPECT_EQ(r.model_variant_names(), (std::vector<std::string>{"gp", "gp_prior", "gp_mi", "mi"}));
  EXPECT_EQ(r.model_variant("gp_mi").style.label, "Black-DROPS with GP-MI");
  EXPECT_EQ(r.model_variant("gp_mi").style.colour, "#1f77b4");
  EXPECT_LT(r.model_variant("gp_mi").style.rank, r.model_variant("gp_prior").style.rank);
  EXPECT_LT(r.model_variant("mi").style.rank, r.model_variant("gp").style.rank);
  EXPECT_FALSE(r.model_variant("gp").uses_prior);
  EXPECT_TRUE(r.model_variant("mi").uses_prior);
  // The schema's values of model.type are the registry's.
  const std::vector<KeySpec> keys = schema(r, "pendubot");
  const KeySpec& type = key_of(keys, "model.type");
  EXPECT_EQ(type.allowed, r.model_variant_names());
  EXPECT_EQ(type.default_value, "gp_mi");
  EXPECT_NE(type.doc.find("gp_mi: with GP-MI"), std::string::npos) << type.doc;
}

TEST(ModelVariants, AnUnregisteredModelTypeIsRefusedListingTheRegisteredOnes) {
  try {
    fixtures::settings("", {"model.type=counting_gp"});
    FAIL() << "model.type=counting_gp was accepted";
  } catch (const ConfigError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("model.type"), std::string::npos) << m;
    EXPECT_NE(m.find("gp, gp_prior, gp_mi, mi"), std::string::npos) << m;
  }
  EXPECT_THROW(fixtures::registry().model_variant("counting_gp"), ConfigError);
}

TEST(ModelVariants, RegistrationRefusesTakenOrBadNamesMissingFactoriesAndBadColours) {
  int made = 0, learns = 0;
  auto r = registry_with_own_variant(&made, &learns);
  const ModelVariant good = r->model_variant("counting_gp");
  auto refused = [&](ModelVariant v, const std::string& why) {
    try {
      r->add_model_variant(std::move(v));
      ADD_FAILURE() << "accepted; expected: " << why;
    } catch (const InvalidArgument& e) {
      EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
    }
  };
  refused(good, "exists");
  ModelVariant v = good;
  v.name = "ite";
  refused(v, "is an algorithm");
  v.name = "Counting";
  refused(v, "lower-case");
  v.name = "other";
  v.factory = nullptr;
  refused(v, "no factory");
  v = good;
  v.name = "other";
  v.style.colour = "red";
  refused(v, "#rrggbb");
  v.style.colour = "#12345g";
  refused(v, "#rrggbb");
  v.style.colour = "";
  v.style.rank = -1;
  refused(v, "rank");
  EXPECT_EQ(r->model_variant_names().size(), 5u);
}

// The whole path of a model of one's own: registered, chosen by model.type in the config, built
// once and learned before each episode after the first by Black-DROPS, recorded in the run
// directory with its style, and labelled, ordered and coloured by the report from that record
// alone (a reader that does not know the variant, like a drops without it, shows it the same).
TEST(ModelVariants, AVariantOfOnesOwnIsSelectedByModelTypeRunAndLabelledInTheReport) {
  int made = 0, learns = 0;
  const auto registry = registry_with_own_variant(&made, &learns);
  const fs::path tmp =
      fs::temp_directory_path() / ("drops-test-model-variants-" + std::to_string(::getpid()));
  fs::remove_all(tmp);
  const Settings settings = load_settings(
      *registry, "model:\n  type: counting_gp\n",
      {"episodes=3", "optimizer.max_evaluations=200", "optimizer.prior_optimizations=1"});
  const Experiment e = make_experiment(*registry, settings);
  EXPECT_EQ(e.variant, "counting_gp");
  EXPECT_TRUE(e.uses_prior);
  EXPECT_EQ(e.default_run_name(""), "pendubot-counting_gp-tunable-useful-seed1");
  const fs::path dir = tmp / "runs" / "own";
  {
    RunDirectory rd(dir, to_yaml(*registry, e.settings), e);
    algo::Callbacks cb;
    cb.on_episode = [&](const algo::EpisodeRecord& rec) { rd.record(rec); };
    cb.on_state = [&](const algo::RunState& s) { rd.save_state(s); };
    rd.finish(e.runner->run(e.setup.problem(), cb), "complete");
  }
  EXPECT_EQ(made, 1);
  EXPECT_EQ(learns, 2);  // before episodes 2 and 3

  const auto s = nlohmann::json::parse(read(dir / "summary.json"));
  EXPECT_EQ(s.at("model"), "counting_gp");
  EXPECT_EQ(s.at("variant_style").at("label"), "GP with priors (counted)");
  EXPECT_EQ(s.at("variant_style").at("rank"), 8);
  EXPECT_EQ(s.at("variant_style").at("colour"), "#e377c2");
  EXPECT_EQ(s.at("episodes").size(), 3u);

  // Read back without the registry that knows the variant: the record is enough.
  const RunResult alone = read_run(dir, &fixtures::registry());
  EXPECT_EQ(alone.status, "complete");
  EXPECT_EQ(alone.model_type, "counting_gp");
  EXPECT_EQ(alone.variant_style.label, "GP with priors (counted)");
  EXPECT_EQ(alone.episodes.size(), 3u);

  // A report of it beside a gp_mi run: gp_mi first (rank 0), then the own variant (rank 8).
  const Experiment m = make_experiment(*registry, load_settings(*registry, "", {"episodes=1"}));
  {
    RunDirectory rd(tmp / "runs" / "gp_mi", to_yaml(*registry, m.settings), m);
    algo::Callbacks cb;
    cb.on_episode = [&](const algo::EpisodeRecord& rec) { rd.record(rec); };
    rd.finish(m.runner->run(m.setup.problem(), cb), "complete");
  }
  const std::vector<const Registry*> readers = {registry.get(), &fixtures::registry()};
  for (const Registry* reader : readers) {
    const CampaignReport rep = aggregate_campaign(*reader, tmp);
    ASSERT_EQ(rep.groups.size(), 2u);
    EXPECT_EQ(rep.groups[0].variant, "gp_mi");
    EXPECT_EQ(rep.groups[1].variant, "counting_gp");
    write_returns_csv(rep, tmp / "returns.csv");
    write_report_markdown(rep, tmp / "report.md");
    const std::string returns = read(tmp / "returns.csv");
    EXPECT_NE(returns.find("counting_gp,tunable-useful,3,7.5,1,"), std::string::npos) << returns;
    EXPECT_NE(returns.find(",GP with priors (counted),A tunable & useful,#e377c2\n"),
              std::string::npos)
        << returns;
    EXPECT_NE(returns.find(",Black-DROPS with GP-MI,A tunable & useful,#1f77b4\n"),
              std::string::npos)
        << returns;
    const std::string md = read(tmp / "report.md");
    EXPECT_NE(md.find("gp_mi = Black-DROPS with GP-MI; counting_gp = GP with priors (counted)"),
              std::string::npos)
        << md;
  }
  std::vector<int> episodes = {3};
  write_plot_data(alone, episodes, tmp / "plot-data.json");
  const auto plot = nlohmann::json::parse(read(tmp / "plot-data.json"));
  EXPECT_EQ(plot.at("variant_label"), "GP with priors (counted)");
  EXPECT_EQ(plot.at("variant_colour"), "#e377c2");

  // The plot script colours each variant as declared, from returns.csv alone.
  if (matplotlib_available()) {
    const fs::path check = tmp / "check.py";
    std::ofstream(check) << "import csv, sys\nsys.path.insert(0, \"" << DROPS_TEST_PYTHON_DIR
                         << "\")\nimport drops_plot as d\nrows = list(csv.DictReader(open(\""
                         << (tmp / "returns.csv").string() << "\")))\n"
                         << "c = d.variant_colors(rows)\n"
                            "sys.exit(0 if c == {'gp_mi': '#1f77b4', 'counting_gp': '#e377c2'} "
                            "else f'{c}')\n";
    EXPECT_EQ(std::system(("/usr/bin/python3 " + check.string()).c_str()), 0);
  }
  fs::remove_all(tmp);
}
