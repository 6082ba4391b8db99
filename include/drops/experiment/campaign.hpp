#pragma once
/// \file The campaign file (docs/campaigns.md): a grid of experiments, its one parser and expansion
/// into runs, the comparison of a run's settings with an existing run directory's, and the
/// campaign directory's one reader and writer (CampaignDirectory). Both `drops campaign` (which
/// runs it) and `drops report` (which reads it back) use this.
///
///   name: my-campaign         # campaign directory name (default: the file's stem)
///   output: campaigns         # parent directory
///   jobs: 2                   # runs at once (local)
///   threads: 1                # worker threads of each run
///   grid: {model.type: [gp_mi, mi], seed: {first: 1, count: 5}}
///   settings: {task: cartpole, episodes: 15}

#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "drops/experiment/config.hpp"

namespace drops::experiment {

class Registry;

/// One axis of a campaign grid: a drops config key and the values it takes.
struct GridAxis {
  std::string key;                  ///< dotted drops config key, e.g. "model.type"
  std::vector<std::string> values;  ///< each value as YAML text (scalars unquoted), file order
};

/// A parsed and checked campaign file.
struct CampaignSpec {
  std::string name;                  ///< campaign directory name (default: the file's stem)
  std::string output = "campaigns";  ///< parent directory; the campaign is <output>/<name>
  int jobs = 0;                      ///< parallel local runs; 0 = hardware threads / threads
  int threads = 1;                   ///< worker threads of each run (>= 1)
  std::vector<GridAxis> grid;        ///< axes in file order (at least one)
  std::string settings_yaml;         ///< the `settings:` block (shared by every run) as YAML
};

/// One run of a campaign, resolved and validated.
struct CampaignRun {
  std::string name;   ///< run name, e.g. "gp_mi-tunable-useful-seed1"
  Settings settings;  ///< every key; output "runs", name = the run name, threads per run
  std::vector<std::pair<std::string, std::string>> values;  ///< this run's grid values (file order)
};

/// Config keys that a campaign sets for every run (directory and threads); they may not appear in
/// its grid or settings.
const std::vector<std::string>& campaign_owned_keys();

/// Parses a campaign file's text. default_name: the name used when the file has no `name`.
/// Checks every key (unknown keys get a did-you-mean), the grid's shape (lists of distinct values,
/// or {first: N, count: M[, step: S]} for integer ranges) and, with `validate`, each grid value
/// against the schema of the campaign's task. Without `validate` (reading a campaign back, perhaps
/// of a task this build does not offer) the grid's keys are taken as written: every mapping that
/// is not a range spells a dotted key. Throws ConfigError naming the key, the value and what is
/// allowed. Thread-safe.
CampaignSpec parse_campaign(const Registry& registry, const std::string& yaml_text,
                            const std::string& default_name, bool validate = true);

/// Reads and parses a campaign file (default name: the file's stem). Throws ConfigError (with the
/// file name) when it cannot be read or is invalid. Thread-safe.
CampaignSpec load_campaign_file(const Registry& registry, const std::string& path,
                                bool validate = true);

/// Every run of the campaign in execution order: the `seed` axis varies slowest, the other axes
/// in file order with the last one fastest. Each run's Settings are loaded and validated in full
/// (load_settings); with `build`, each experiment is also built (make_experiment), which checks
/// what the schema alone cannot. Run names join the grid values in file order with '-' (seed N is
/// written "seedN"; other characters outside [A-Za-z0-9_.-] become '_'). Throws ConfigError
/// naming the run and the key.
std::vector<CampaignRun> expand_campaign(const Registry& registry, const CampaignSpec& spec,
                                         bool build = true);

/// The part of a run name contributed by one grid value (see expand_campaign).
std::string run_name_part(const std::string& key, const std::string& value_text);

/// True when a and b hold the same value for every key except those in `ignore`; numbers are
/// compared as numbers ("1e-3" == "0.001"), lists element by element, an empty value equals a
/// null one. On a difference, stores the first differing key in *key (when key is not null).
/// Thread-safe.
bool same_settings(const Settings& a, const Settings& b, const std::vector<std::string>& ignore,
                   std::string* key = nullptr);

/// Whether two setting values (YAML text) are the same: numbers as numbers, lists element by
/// element, an empty value equal to a null one. Thread-safe.
bool same_setting_value(const std::string& a, const std::string& b);

/// Why two campaign specs describe different campaigns: "" when only jobs, threads, name or
/// output differ, else a sentence naming the first difference (an axis, its values, a setting).
/// A setting `a` leaves to its default and `b` sets is no difference (a changed default pinned
/// to its old value; the run directories' own settings decide whether the runs made agree).
std::string campaign_difference(const Registry& registry, const CampaignSpec& a,
                                const CampaignSpec& b);

/// The campaign directory <output>/<name>/ (docs/campaigns.md): its layout, written by `drops
/// campaign` and read back by `drops campaign` (to continue it) and `drops report`:
///   campaign.yaml        copy of the campaign file
///   campaign.log         one JSON object per line (appended and flushed): begin, start, resume,
///                        finish, skip, end
///   configs/<run>.yaml   each run's resolved configuration (to_yaml)
///   runs/<run>/          the run directory written by `drops run`
///   runs/<run>.log       the run's stdout and stderr (appended)
///   .lock                held (flock) by the coordinating process while the campaign runs
/// The paths below are the layout's; the object holds only the directory. Thread-safe (const).
class CampaignDirectory {
 public:
  explicit CampaignDirectory(std::filesystem::path dir) : dir_(std::move(dir)) {}
  const std::filesystem::path& path() const { return dir_; }
  std::filesystem::path campaign_file() const { return dir_ / "campaign.yaml"; }
  std::filesystem::path log_file() const { return dir_ / "campaign.log"; }
  std::filesystem::path lock_file() const { return dir_ / ".lock"; }
  std::filesystem::path configs() const { return dir_ / "configs"; }
  std::filesystem::path runs() const { return dir_ / "runs"; }
  std::filesystem::path run_config(const std::string& run) const {
    return configs() / (run + ".yaml");
  }
  std::filesystem::path run(const std::string& run) const { return runs() / run; }
  std::filesystem::path run_log(const std::string& run) const { return runs() / (run + ".log"); }

  /// Creates the directory with configs/ and runs/, writes campaign.yaml (file_text) and each
  /// run's configs/<run>.yaml (rewritten only when its text changes). Throws Error when a file
  /// cannot be written.
  void write(const Registry& registry, const std::string& file_text,
             const std::vector<CampaignRun>& runs) const;
  /// The campaign file kept in the directory, parsed (parse_campaign with default_name and
  /// validate); nullopt when there is none. Throws ConfigError naming the file when it cannot be
  /// read or parsed.
  std::optional<CampaignSpec> read_spec(const Registry& registry, const std::string& default_name,
                                        bool validate) const;
  /// The `status` of runs/<run>/summary.json ("running", "interrupted", "failed", "complete"),
  /// or "" when there is none or it cannot be read.
  std::string run_status(const std::string& run) const;
  /// Whether runs/<run>/ holds a checkpoint.json (an interrupted run can be continued).
  bool run_has_checkpoint(const std::string& run) const;
  /// Checks that the existing run directory of `run` can be kept for this campaign: its format
  /// version is this drops' (check_run_directory_format) and its config.yaml has the run's
  /// settings (same_settings, the keys the campaign owns aside, task-dependent defaults
  /// resolved). Throws ConfigError naming the run, the directory and the first differing key,
  /// with what to do.
  void check_kept_run(const Registry& registry, const CampaignRun& run) const;

 private:
  std::filesystem::path dir_;
};

}  // namespace drops::experiment
