// Reader and writer of the MAP-Elites archive file (format in drops/ite/archive_io.hpp).
#include "drops/ite/archive_io.hpp"

#include <charconv>
#include <cmath>
#include <optional>
#include <sstream>
#include <string>
#include <string_view>
#include <system_error>
#include <type_traits>
#include <vector>

#include "drops/core/errors.hpp"

namespace drops::ite {

namespace {

constexpr std::string_view kMagic = "# drops-map-elites-archive 1";

void append_double(std::string& s, double v) {
  char buffer[64];
  const auto r = std::to_chars(buffer, buffer + sizeof buffer, v);  // shortest round trip
  s.append(buffer, r.ptr);
}

std::string column_header(int k, int param_dim) {
  std::string h;
  for (int d = 0; d < k; ++d) h += "cell_" + std::to_string(d) + ",";
  for (int d = 0; d < k; ++d) h += "descriptor_" + std::to_string(d) + ",";
  h += "fitness";
  for (int i = 0; i < param_dim; ++i) h += ",theta_" + std::to_string(i);
  return h;
}

[[noreturn]] void fail(long line, const std::string& what) {
  throw InvalidArgument("archive file, line " + std::to_string(line) + ": " + what);
}

std::vector<std::string_view> split(std::string_view s, char sep) {
  std::vector<std::string_view> out;
  std::size_t start = 0;
  while (true) {
    const std::size_t p = s.find(sep, start);
    out.push_back(
        s.substr(start, p == std::string_view::npos ? std::string_view::npos : p - start));
    if (p == std::string_view::npos) return out;
    start = p + 1;
  }
}

template <class T>
T parse(std::string_view field, long line, const char* what) {
  T v{};
  const auto r = std::from_chars(field.data(), field.data() + field.size(), v);
  if (r.ec != std::errc() || r.ptr != field.data() + field.size()) {
    fail(line, std::string("expected ") + what + ", got '" + std::string(field) + "'");
  }
  if constexpr (std::is_floating_point_v<T>) {
    if (!std::isfinite(v)) {
      fail(line, std::string("expected a finite ") + what + ", got '" + std::string(field) + "'");
    }
  }
  return v;
}

std::string_view trim_cr(std::string_view s) {
  if (!s.empty() && s.back() == '\r') s.remove_suffix(1);
  return s;
}

}  // namespace

void write_archive(std::ostream& out, const Archive& archive,
                   const std::vector<std::string>& comments) {
  const int k = archive.descriptor_dim();
  std::string s;
  s += kMagic;
  s += "\n# bins";
  for (int n : archive.bins()) {
    s += ' ';
    s += std::to_string(n);
  }
  s += "\n# param_dim ";
  s += std::to_string(archive.param_dim());
  s += '\n';
  s += "# binning floor: cell_d = min(floor(descriptor_d * bins_d), bins_d - 1)\n";
  for (const std::string& c : comments) {
    if (c.find_first_of("\n\r") != std::string::npos)
      throw InvalidArgument("write_archive: a comment must be one line, got '" + c + "'");
    s += "# " + c + "\n";
  }
  s += column_header(k, archive.param_dim()) + "\n";
  out << s;
  for (const Elite& e : archive.elites()) {
    s.clear();
    for (int d = 0; d < k; ++d) s += std::to_string(e.cell[d]) + ",";
    for (int d = 0; d < k; ++d) {
      append_double(s, e.descriptor[d]);
      s += ',';
    }
    append_double(s, e.fitness);
    for (Eigen::Index i = 0; i < e.theta.size(); ++i) {
      s += ',';
      append_double(s, e.theta[i]);
    }
    s += '\n';
    out << s;
  }
  out.flush();
  if (!out) throw Error("write_archive: the stream failed while writing the archive");
}

Archive read_archive(std::istream& in, std::vector<std::string>* comments) {
  std::string raw;
  long line = 0;
  if (!std::getline(in, raw) || trim_cr(raw) != kMagic) {
    fail(1, "expected the first line '" + std::string(kMagic) + "'");
  }
  ++line;
  std::optional<std::vector<int>> bins;
  std::optional<int> param_dim;
  // Preamble: comment lines up to the column header.
  while (true) {
    if (!std::getline(in, raw)) fail(line + 1, "expected the column header, got the end of file");
    ++line;
    const std::string_view s = trim_cr(raw);
    if (s.empty() || s.front() != '#') break;
    std::istringstream words{std::string(s.substr(1))};
    std::string key;
    words >> key;
    if (key == "bins") {
      std::vector<int> b;
      std::string w;
      while (words >> w) b.push_back(parse<int>(w, line, "an integer number of bins"));
      if (b.empty()) fail(line, "expected '# bins n_0 n_1 ...', got no numbers");
      bins = std::move(b);
    } else if (key == "param_dim") {
      std::string w;
      if (!(words >> w)) fail(line, "expected '# param_dim <integer>'");
      param_dim = parse<int>(w, line, "an integer param_dim");
    } else if (key != "binning" && comments != nullptr) {
      std::string_view c = s.substr(1);
      if (!c.empty() && c.front() == ' ') c.remove_prefix(1);
      comments->emplace_back(c);
    }
  }
  if (!bins) fail(line, "expected a '# bins ...' line before the column header");
  if (!param_dim) fail(line, "expected a '# param_dim ...' line before the column header");
  Archive archive = [&] {
    try {
      return Archive(*bins, *param_dim);
    } catch (const InvalidArgument& error) {
      fail(line, error.what());
    }
  }();
  const int k = archive.descriptor_dim();
  const int p = archive.param_dim();
  const std::string header = column_header(k, p);
  if (trim_cr(raw) != header) {
    fail(line, "expected the column header '" + header + "', got '" + raw + "'");
  }
  const std::size_t fields = static_cast<std::size_t>(2 * k + 1 + p);
  while (std::getline(in, raw)) {
    ++line;
    const std::string_view s = trim_cr(raw);
    if (s.empty()) continue;
    const auto f = split(s, ',');
    if (f.size() != fields) {
      fail(line, "expected " + std::to_string(fields) + " fields, got " + std::to_string(f.size()));
    }
    Elite e;
    e.cell.resize(k);
    e.descriptor.resize(k);
    e.theta.resize(p);
    for (int d = 0; d < k; ++d) e.cell[d] = parse<int>(f[d], line, "an integer cell index");
    for (int d = 0; d < k; ++d) e.descriptor[d] = parse<double>(f[k + d], line, "descriptor value");
    e.fitness = parse<double>(f[2 * k], line, "fitness");
    for (int i = 0; i < p; ++i) e.theta[i] = parse<double>(f[2 * k + 1 + i], line, "parameter");
    try {
      archive.restore(std::move(e));
    } catch (const InvalidArgument& error) {
      fail(line, error.what());
    }
  }
  if (in.bad()) throw Error("read_archive: the stream failed while reading the archive");
  return archive;
}

}  // namespace drops::ite
