#include "drops/experiment/registry.hpp"

#include <algorithm>

#include "drops/core/errors.hpp"

namespace drops::experiment {
namespace {
std::string joined(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& a : v) s += (s.empty() ? "" : ", ") + a;
  return s;
}

bool valid_name(const std::string& name) {
  return !name.empty() &&
         name.find_first_not_of("abcdefghijklmnopqrstuvwxyz0123456789_") == std::string::npos;
}
}  // namespace

bool VariantStyle::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (rank < 0) return fail("rank must be >= 0, got " + std::to_string(rank));
  if (!colour.empty() &&
      (colour.size() != 7 || colour[0] != '#' ||
       colour.find_first_not_of("0123456789abcdefABCDEF", 1) != std::string::npos))
    return fail("colour must be empty or #rrggbb, got '" + colour + "'");
  return true;
}

algo::Problem TaskSetup::problem() const {
  algo::Problem p;
  p.task = task;
  p.real = real.get();
  p.policy = policy.get();
  p.prior = prior;
  p.prior_parameters = prior_parameters;
  return p;
}

bool TaskPlugin::is_prior_key(const std::string& key) const {
  return key.rfind("prior.", 0) == 0 || key.rfind(name() + ".prior.", 0) == 0;
}

Panel model_free_panel() {
  Panel p;
  p.label = "no model";
  p.rank = 1000;  // after the task's panels
  p.title = "no model or prior: search on the real system";
  p.chosen_by_prior = false;
  return p;
}

ReportInfo run_report_info(ReportInfo task, bool uses_prior, bool uses_model) {
  if (!uses_prior && !uses_model && task.panel.chosen_by_prior) task.panel = model_free_panel();
  return task;
}

void Registry::add_task(std::unique_ptr<TaskPlugin> task) {
  if (!task) throw InvalidArgument("Registry::add_task: null task");
  const std::string name = task->name();
  if (!valid_name(name))
    throw InvalidArgument("Registry::add_task: task name '" + name +
                          "': expected lower-case letters, digits and _");
  if (has_task(name)) throw InvalidArgument("Registry::add_task: task '" + name + "' exists");
  std::vector<KeySpec> keys = task->keys();
  for (const auto& k : keys) {
    bool taken = false;
    for (const auto& b : base_keys()) taken = taken || b.key == k.key;
    for (const auto& a : algorithms_)
      for (const auto& ak : a->keys()) taken = taken || ak.key == k.key;
    if (taken)
      throw InvalidArgument("Registry::add_task: task '" + name + "' declares key '" + k.key +
                            "', which is a base or algorithm key");
  }
  unavailable_.erase(name);
  task_keys_.push_back(std::move(keys));
  tasks_.push_back(std::move(task));
}

void Registry::add_unavailable_task(const std::string& name, const std::string& reason) {
  if (!has_task(name)) unavailable_[name] = reason;
}

void Registry::add_algorithm(std::unique_ptr<AlgorithmPlugin> algorithm) {
  if (!algorithm) throw InvalidArgument("Registry::add_algorithm: null algorithm");
  const std::string name = algorithm->name();
  for (const auto& a : algorithms_)
    if (a->name() == name)
      throw InvalidArgument("Registry::add_algorithm: algorithm '" + name + "' exists");
  for (const auto& m : model_variants_)
    if (m.name == name)
      throw InvalidArgument("Registry::add_algorithm: '" + name +
                            "' is a model variant (reports could not tell their runs apart)");
  for (const auto& k : algorithm->keys()) {
    bool taken = task_of_key(k.key) != nullptr;
    for (const auto& b : base_keys()) taken = taken || b.key == k.key;
    for (const auto& a : algorithms_)
      for (const auto& ak : a->keys()) taken = taken || ak.key == k.key;
    if (taken)
      throw InvalidArgument("Registry::add_algorithm: algorithm '" + name + "' declares key '" +
                            k.key + "', which exists already");
  }
  algorithms_.push_back(std::move(algorithm));
}

void Registry::add_model_variant(ModelVariant variant) {
  const std::string head = "Registry::add_model_variant: model variant '" + variant.name + "': ";
  if (!valid_name(variant.name))
    throw InvalidArgument(head + "expected lower-case letters, digits and _");
  for (const auto& m : model_variants_)
    if (m.name == variant.name) throw InvalidArgument(head + "exists");
  for (const auto& a : algorithms_)
    if (a->name() == variant.name)
      throw InvalidArgument(head + "is an algorithm (reports could not tell their runs apart)");
  if (!variant.factory) throw InvalidArgument(head + "no factory");
  std::string why;
  if (!variant.style.IsValid(&why)) throw InvalidArgument(head + "style: " + why);
  model_variants_.push_back(std::move(variant));
}

const ModelVariant& Registry::model_variant(const std::string& name) const {
  for (const auto& m : model_variants_)
    if (m.name == name) return m;
  throw ConfigError("config key 'model.type' = '" + name +
                    "': unknown model variant (available: " + joined(model_variant_names()) + ")");
}

std::vector<std::string> Registry::model_variant_names() const {
  std::vector<std::string> v;
  for (const auto& m : model_variants_) v.push_back(m.name);
  return v;
}

const TaskPlugin& Registry::task(const std::string& name) const {
  for (const auto& t : tasks_)
    if (t->name() == name) return *t;
  const auto u = unavailable_.find(name);
  if (u != unavailable_.end())
    throw ConfigError("config key 'task' = '" + name + "': this drops does not offer the task: " +
                      u->second);
  throw ConfigError("config key 'task' = '" + name + "': unknown task (available: " +
                    joined(task_names()) +
                    "); a task written in Python runs from Python, with its objects: "
                    "drops.run(config, task=..., system=..., prior=...) (docs/python.md)");
}

const AlgorithmPlugin& Registry::algorithm(const std::string& name) const {
  for (const auto& a : algorithms_)
    if (a->name() == name) return *a;
  throw ConfigError("config key 'algorithm' = '" + name + "': unknown algorithm (available: " +
                    joined(algorithm_names()) + ")");
}

bool Registry::has_task(const std::string& name) const {
  return std::any_of(tasks_.begin(), tasks_.end(),
                     [&](const auto& t) { return t->name() == name; });
}

std::vector<std::string> Registry::task_names() const {
  std::vector<std::string> v;
  for (const auto& t : tasks_) v.push_back(t->name());
  return v;
}

std::vector<std::string> Registry::algorithm_names() const {
  std::vector<std::string> v;
  for (const auto& a : algorithms_) v.push_back(a->name());
  return v;
}

std::string Registry::default_task() const {
  if (tasks_.empty()) throw ConfigError("no task is registered");
  return tasks_.front()->name();
}

std::string Registry::default_algorithm() const {
  if (algorithms_.empty()) throw ConfigError("no algorithm is registered");
  return algorithms_.front()->name();
}

const TaskPlugin* Registry::task_of_key(const std::string& key) const {
  for (std::size_t i = 0; i < tasks_.size(); ++i)
    for (const auto& k : task_keys_[i])
      if (k.key == key) return tasks_[i].get();
  return nullptr;
}

}  // namespace drops::experiment
