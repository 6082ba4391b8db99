// The archive file of IT&E runs: ite's archive rows plus comments saying what the archive is.
#include "drops/experiment/archive_file.hpp"

#include <fmt/format.h>

#include <fstream>
#include <sstream>

#include "drops/core/errors.hpp"
#include "drops/experiment/experiment.hpp"
#include "drops/experiment/registry.hpp"
#include "drops/experiment/run_directory.hpp"
#include "drops/ite/archive_io.hpp"

namespace drops::experiment {
namespace fs = std::filesystem;
namespace {

/// Replaces line breaks so that a text fits on one comment line.
std::string one_line(std::string s) {
  for (char& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  return s;
}

/// "key rest of line" -> (key, rest).
std::pair<std::string, std::string> split_key(const std::string& line) {
  const auto space = line.find(' ');
  if (space == std::string::npos) return {line, ""};
  return {line.substr(0, space), line.substr(space + 1)};
}

}  // namespace

ArchiveFileInfo archive_file_info(const std::string& task, const TaskSetup& setup) {
  ArchiveFileInfo info;
  info.task = task;
  info.prior = setup.prior_label;
  if (const ite::BehaviourDescriptor* behaviour = task_behaviour(setup)) {
    info.descriptor_names = behaviour->names;
    info.descriptor_doc = behaviour->doc;
  }
  if (setup.task)
    info.fitness_doc = fmt::format(
        "the return of an episode of {} steps of {} s on the prior {} (deterministic)",
        setup.task->horizon(), setup.task->dt(), setup.prior_label);
  return info;
}

void write_archive_file(const fs::path& path, const ite::Archive& archive,
                        const ArchiveFileInfo& info) {
  std::vector<std::string> comments;
  auto add = [&](const char* key, const std::string& value) {
    if (!value.empty()) comments.push_back(fmt::format("{} {}", key, one_line(value)));
  };
  add("task", info.task);
  add("prior", info.prior);
  std::string names;
  for (const auto& n : info.descriptor_names) {
    if (!names.empty()) names += ' ';
    names += one_line(n);
  }
  add("descriptor", names);
  add("descriptor_doc", info.descriptor_doc);
  add("fitness", info.fitness_doc);
  const auto& c = info.cursor;
  comments.push_back(fmt::format(
      "map_elites complete {} evaluations {} batches {} generations {} initial_drawn {} "
      "initial_left {}",
      info.complete ? 1 : 0, c.evaluations, c.batches, c.generations, c.initial_drawn,
      c.initial_left));
  std::ostringstream out;
  ite::write_archive(out, archive, comments);
  write_file_atomically(path, out.str());
}

ArchiveFile read_archive_file(const fs::path& path) {
  std::istringstream in(read_file_text(path));
  std::vector<std::string> comments;
  ArchiveFile file;
  try {
    file.archive = std::make_shared<const ite::Archive>(ite::read_archive(in, &comments));
  } catch (const InvalidArgument& e) {
    throw Error(path.string() + ": " + e.what());
  }
  ArchiveFileInfo& info = file.info;
  for (const auto& line : comments) {
    const auto [key, rest] = split_key(line);
    if (key == "task") {
      info.task = rest;
    } else if (key == "prior") {
      info.prior = rest;
    } else if (key == "descriptor") {
      std::istringstream words(rest);
      std::string w;
      while (words >> w) info.descriptor_names.push_back(w);
    } else if (key == "descriptor_doc") {
      info.descriptor_doc = rest;
    } else if (key == "fitness") {
      info.fitness_doc = rest;
    } else if (key == "map_elites") {
      std::istringstream words(rest);
      std::string name;
      long long value = 0;
      int seen = 0;
      while (words >> name >> value) {
        ++seen;
        if (name == "complete") info.complete = value != 0;
        else if (name == "evaluations") info.cursor.evaluations = value;
        else if (name == "batches") info.cursor.batches = static_cast<int>(value);
        else if (name == "generations") info.cursor.generations = value;
        else if (name == "initial_drawn") info.cursor.initial_drawn = value;
        else if (name == "initial_left") info.cursor.initial_left = value;
        else --seen;
      }
      if (seen != 6 || !words.eof())
        throw Error(path.string() + ": malformed comment '# " + line +
                    "' (expected: map_elites complete C evaluations N batches B generations G "
                    "initial_drawn D initial_left L)");
    }
  }
  if (!info.descriptor_names.empty() &&
      info.descriptor_names.size() != static_cast<std::size_t>(file.archive->descriptor_dim()))
    throw Error(fmt::format("{}: the descriptor line names {} dimensions, the grid has {}",
                            path.string(), info.descriptor_names.size(),
                            file.archive->descriptor_dim()));
  return file;
}

}  // namespace drops::experiment
