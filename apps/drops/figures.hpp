#pragma once
// The figures of `drops report` and `drops plot`: the tables and data files of drops::experiment
// (report.hpp) drawn by python/drops_plot.py through Debian's /usr/bin/python3 (matplotlib).

#include <filesystem>
#include <string>
#include <vector>

#include "drops/experiment/report.hpp"

namespace drops::app {

/// `drops report`: writes report.md, summary.csv, returns.csv and phi.csv into `out_dir` (created
/// if needed), plus the task's metric table (e.g. speed.csv) when a group has it, and, when
/// `figures`, returns.png (and e.g. speed.png). Returns the files written. Throws drops::Error when
/// a file cannot be written or a figure cannot be drawn (Debian's /usr/bin/python3 with matplotlib
/// and numpy is needed; the tables are kept). Not thread-safe with another call on `out_dir`.
std::vector<std::filesystem::path> write_report(const experiment::CampaignReport& report,
                                                const std::filesystem::path& out_dir,
                                                bool figures);

/// `drops plot`: writes plot-data.json (experiment::write_plot_data) and draws returns.png,
/// phi.png (when the run uses a prior), trajectories-NNN.png for each episode of `episodes`
/// ("1,5,10"; empty = experiment::default_plot_episodes), the task's own figures and, for a run
/// with an archive.csv (IT&E), archive.png into `out_dir`.
/// Returns the files written. Throws ConfigError when `run_dir` is not a started run directory or
/// the episode list is invalid, drops::Error when the run has no episode, a trajectory file is
/// missing or python/matplotlib fails.
/// Draws an IT&E archive file (experiment::read_archive_file's format) into `output_png`
/// (its folder created if needed): the grid coloured by fitness, the coverage per descriptor value
/// and the fitness distribution. Throws drops::Error when the file is not an archive or
/// python/matplotlib fails.
void plot_archive(const std::filesystem::path& archive_csv,
                  const std::filesystem::path& output_png);

/// `drops identify`: draws validation-NN.png (recorded against open-loop predicted trajectories,
/// from validation-NN.csv) and phi.png (from phi.csv, when it has a tunable parameter) into the
/// identify directory `dir` (experiment::write_identify_directory). Returns the files drawn.
/// Throws drops::Error when python/matplotlib fails (the directory's other files are kept).
std::vector<std::filesystem::path> plot_identify(const std::filesystem::path& dir);

std::vector<std::filesystem::path> plot_run(const experiment::Registry& registry,
                                            const std::filesystem::path& run_dir,
                                            const std::string& episodes,
                                            const std::filesystem::path& out_dir);

}  // namespace drops::app
