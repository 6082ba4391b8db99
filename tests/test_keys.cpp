// KeyTable (drops/experiment/keys.hpp): a key declared once gives its spec (type, default from the
// struct's initialiser, range, allowed values) and sets its field from settings.
#include <gtest/gtest.h>

#include <optional>

#include "drops/core/errors.hpp"
#include "drops/experiment/keys.hpp"

using namespace drops;
using experiment::KeySpec;
using experiment::KeyTable;
using experiment::Settings;

namespace {

enum class Mode { kFast, kExact };

struct Inner {
  double tol = 0.01, tol_copy = 0.01;
  long budget = 1000;
  long run_budget = 0;
};

struct Toy {
  int count = 3;
  double rate = 0.25;
  bool on = true;
  std::string path = "runs";
  Mode mode = Mode::kExact;
  std::optional<double> length;
  experiment::Interval box = {0.5, 2.0};
  experiment::Names picked = {"a", "c"};
  int grid = 0;  // optional key: 0 = the task's
  Inner inner;
};

KeyTable<Inner> inner_table() {
  KeyTable<Inner> t;
  t.add("toy.inner.tol", [](auto& o) -> auto& { return o.tol; })
      .also([](auto& o) -> auto& { return o.tol_copy; })
      .range(0, 1);
  // Declared before the key it follows: derived() rules run after every key is applied.
  t.add("toy.inner.run_budget", [](auto& o) -> auto& { return o.run_budget; })
      .derived([](const Inner& o) { return o.budget / 4; })
      .range(0, 1e9);
  t.add("toy.inner.budget", [](auto& o) -> auto& { return o.budget; }).range(1, 1e9);
  return t;
}

KeyTable<Toy> toy_table() {
  KeyTable<Toy> t;
  t.add("toy.count", &Toy::count).range(1, 10).help("how many");
  t.add("toy.rate", &Toy::rate).range(0, 1).unit("1/s");
  t.add("toy.on", &Toy::on);
  t.add("toy.path", &Toy::path);
  t.add("toy.mode", &Toy::mode).values({{"fast", Mode::kFast}, {"exact", Mode::kExact}});
  t.add("toy.length", &Toy::length).range(0.1, 5).unit("m");
  t.add("toy.box", &Toy::box).range(0, 10);
  t.add("toy.picked", &Toy::picked).allowed({"a", "b", "c"});
  t.add("toy.grid", &Toy::grid).optional().range(1, 100);
  t.include(inner_table(), &Toy::inner);
  return t;
}

const KeySpec& spec(const std::vector<KeySpec>& specs, const std::string& key) {
  for (const auto& s : specs)
    if (s.key == key) return s;
  throw std::out_of_range(key);
}

}  // namespace

TEST(Keys, TheSpecsTypesAndDefaultsComeFromTheFieldsAndTheirInitialisers) {
  const auto specs = toy_table().specs();
  ASSERT_EQ(specs.size(), 12u);
  EXPECT_EQ(specs.front().key, "toy.count");  // declaration order
  const std::vector<std::vector<std::string>> want = {
      {"toy.count", "int", "3"},          {"toy.rate", "double", "0.25"},
      {"toy.on", "bool", "true"},         {"toy.path", "string", "runs"},
      {"toy.mode", "enum", "exact"},      {"toy.length", "double", ""},
      {"toy.box", "interval", "[0.5, 2]"}, {"toy.picked", "names", "[a, c]"},
      {"toy.grid", "int", ""},            {"toy.inner.tol", "double", "0.01"},
      {"toy.inner.budget", "int", "1000"}};
  for (const auto& w : want) {
    const KeySpec& s = spec(specs, w[0]);
    EXPECT_EQ(s.type, w[1]) << w[0];
    EXPECT_EQ(s.default_value, w[2]) << w[0];
  }
  EXPECT_EQ(spec(specs, "toy.mode").allowed, (std::vector<std::string>{"fast", "exact"}));
  EXPECT_EQ(spec(specs, "toy.picked").allowed, (std::vector<std::string>{"a", "b", "c"}));
  EXPECT_EQ(spec(specs, "toy.rate").unit, "1/s");
  EXPECT_EQ(spec(specs, "toy.on").unit, "-");
  EXPECT_EQ(spec(specs, "toy.count").doc, "how many");
  EXPECT_DOUBLE_EQ(spec(specs, "toy.count").min, 1);
  EXPECT_DOUBLE_EQ(spec(specs, "toy.count").max, 10);
  // Other defaults, e.g. a task's own: read from the struct given.
  Toy d;
  d.inner.budget = 7;
  d.mode = Mode::kFast;
  d.length = 1.5;
  const auto other = toy_table().specs(d);
  EXPECT_EQ(spec(other, "toy.inner.budget").default_value, "7");
  EXPECT_EQ(spec(other, "toy.mode").default_value, "fast");
  EXPECT_EQ(spec(other, "toy.length").default_value, "1.5");
}

TEST(Keys, ApplySetsEachFieldFromItsSetting) {
  Settings s = {{"toy.count", "7"},        {"toy.rate", "0.5"},          {"toy.on", "false"},
                {"toy.path", "/tmp/x"},    {"toy.mode", "fast"},         {"toy.length", "2.5"},
                {"toy.box", "[1, 3]"},     {"toy.picked", "[b]"},        {"toy.grid", ""},
                {"toy.inner.tol", "0.001"}, {"toy.inner.budget", "5000"},
                {"toy.inner.run_budget", ""}};
  Toy t;
  toy_table().apply(s, t);
  EXPECT_EQ(t.count, 7);
  EXPECT_DOUBLE_EQ(t.rate, 0.5);
  EXPECT_FALSE(t.on);
  EXPECT_EQ(t.path, "/tmp/x");
  EXPECT_EQ(t.mode, Mode::kFast);
  ASSERT_TRUE(t.length.has_value());
  EXPECT_DOUBLE_EQ(*t.length, 2.5);
  EXPECT_EQ(t.box, (experiment::Interval{1, 3}));
  EXPECT_EQ(t.picked, (experiment::Names{"b"}));
  EXPECT_EQ(t.grid, 0);  // empty: the field keeps its value
  EXPECT_DOUBLE_EQ(t.inner.tol, 0.001);
  EXPECT_DOUBLE_EQ(t.inner.tol_copy, 0.001);  // also()
  EXPECT_EQ(t.inner.budget, 5000);
  EXPECT_EQ(t.inner.run_budget, 1250);  // derived(): empty follows the budget, through include()
  EXPECT_EQ(spec(toy_table().specs(), "toy.inner.run_budget").default_value, "");
  s["toy.inner.run_budget"] = "0";
  toy_table().apply(s, t);
  EXPECT_EQ(t.inner.run_budget, 0);  // an explicit value wins
  s["toy.inner.run_budget"] = "";
  s["toy.grid"] = "12";
  s["toy.length"] = "";
  toy_table().apply(s, t);
  EXPECT_EQ(t.grid, 12);
  EXPECT_FALSE(t.length.has_value());
  // A value that no name denotes (settings that did not come from load_settings) names the key.
  s["toy.mode"] = "slow";
  try {
    toy_table().apply(s, t);
    FAIL() << "toy.mode = slow was applied";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("'toy.mode' = 'slow'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("fast, exact"), std::string::npos) << e.what();
  }
}
