#pragma once
/// \file The MAP-Elites archive file: a CSV text format with a commented preamble, written to and
/// read from streams (the caller opens the file). The one reader and writer of this format.
///
/// Format (version 1; docs/ite.md):
///   # drops-map-elites-archive 1
///   # bins 20 20
///   # param_dim 8
///   # binning floor: cell_d = min(floor(descriptor_d * bins_d), bins_d - 1)
///   cell_0,cell_1,descriptor_0,descriptor_1,fitness,theta_0,...,theta_7
///   3,17,0.171,0.853,-0.0123,0.48,...
/// The first line identifies the format; the "bins" and "param_dim" lines are required, in any
/// order, before the column header; other lines starting with '#' are comments. Then one row per
/// elite, in the archive's order (first-fill order): k integer cell indices, k descriptor values,
/// the fitness, param_dim parameters. Reals are written in the shortest form that reads back to the
/// same double, so write -> read gives an identical archive.

#include <istream>
#include <ostream>
#include <string>
#include <vector>

#include "drops/ite/archive.hpp"

namespace drops::ite {

/// Writes `archive` in the format above, with `comments` (one line each, written "# <comment>"
/// after the binning line; e.g. what the descriptor and the fitness are). Throws Error when the
/// stream fails, InvalidArgument when a comment holds a line break. Thread-safe for distinct
/// streams (the archive is only read).
void write_archive(std::ostream& out, const Archive& archive,
                   const std::vector<std::string>& comments = {});

/// Reads an archive written by write_archive. Every row is checked (field count, integers, finite
/// reals, cell indices in range, the descriptor binning into its cell under the floor convention,
/// no cell twice); a bad file throws InvalidArgument naming the line and what was expected. The
/// preamble's other comment lines (all but bins, param_dim and binning), without their "# ", are
/// appended to *comments when it is not null.
Archive read_archive(std::istream& in, std::vector<std::string>* comments = nullptr);

}  // namespace drops::ite
