#include "plugin_index.hpp"

#include <fmt/format.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "varbo/loader.hpp"
#include "varbo/plugin.hpp"
#include "varbo/regular_file.hpp"

namespace fs = std::filesystem;

namespace varbo::detail {

namespace {

// Format: a header line, then per library "lib FILE SIZE MTIME_NS PLUGIN|-" followed by one "c NAME" line per
// component. Names hold no whitespace (plugin names are checked by the loader; component names are identifiers).
std::string header() { return fmt::format("varbo-plugin-index 1 abi {} {}", VARBO_ABI_VERSION, host_fingerprint()); }

}  // namespace

std::optional<std::vector<IndexedLibrary>> list_plugin_files(const std::string& dir) {
  std::error_code ec;
  fs::directory_iterator it(dir, ec), end;
  if (ec) return std::nullopt;
  std::vector<IndexedLibrary> out;
  for (; it != end; it.increment(ec)) {
    if (ec) return std::nullopt;
    const fs::path p = it->path();
    const std::string fname = p.filename().string();
    if (fname.rfind("libvarbo_", 0) != 0 || p.extension() != ".so" || fname == "libvarbo_core.so") continue;
    struct stat st {};
    if (::stat(p.c_str(), &st) != 0) return std::nullopt;
    IndexedLibrary l;
    l.file = fname;
    l.size = static_cast<std::uintmax_t>(st.st_size);
    l.mtime_ns = static_cast<std::int64_t>(st.st_mtim.tv_sec) * 1000000000 + st.st_mtim.tv_nsec;
    out.push_back(std::move(l));
  }
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.file < b.file; });
  return out;
}

std::optional<std::vector<IndexedLibrary>> read_plugin_index(const std::string& dir) {
  const std::string file = (fs::path(dir) / kPluginIndexFile).string();
  if (!absent_or_regular_file(file)) return std::nullopt;  // a FIFO would block every command
  std::ifstream in(file);
  if (!in) return std::nullopt;
  std::string line;
  if (!std::getline(in, line) || line != header()) return std::nullopt;
  std::vector<IndexedLibrary> index;
  while (std::getline(in, line)) {
    std::istringstream ls(line);
    std::string tag;
    ls >> tag;
    if (tag == "lib") {
      IndexedLibrary l;
      if (!(ls >> l.file >> l.size >> l.mtime_ns >> l.plugin)) return std::nullopt;
      if (l.plugin == "-") l.plugin.clear();
      index.push_back(std::move(l));
    } else if (tag == "c" && !index.empty()) {
      std::string name;
      if (!(ls >> name)) return std::nullopt;
      index.back().components.push_back(std::move(name));
    } else {
      return std::nullopt;
    }
  }
  const auto files = list_plugin_files(dir);
  if (!files || files->size() != index.size()) return std::nullopt;
  for (std::size_t i = 0; i < index.size(); ++i)
    if ((*files)[i].file != index[i].file || (*files)[i].size != index[i].size ||
        (*files)[i].mtime_ns != index[i].mtime_ns)
      return std::nullopt;
  return index;
}

void write_plugin_index(const std::string& dir, const std::vector<IndexedLibrary>& libraries) {
  const fs::path target = fs::path(dir) / kPluginIndexFile;
  const fs::path tmp = fs::path(dir) / fmt::format(".{}.{}", kPluginIndexFile, static_cast<long>(getpid()));
  {
    std::ofstream out(tmp);
    if (!out) return;
    out << header() << "\n";
    for (const auto& l : libraries) {
      out << fmt::format("lib {} {} {} {}\n", l.file, l.size, l.mtime_ns, l.plugin.empty() ? "-" : l.plugin);
      for (const auto& c : l.components) out << "c " << c << "\n";
    }
    if (!out.flush()) {
      std::error_code ec;
      fs::remove(tmp, ec);
      return;
    }
  }
  std::error_code ec;
  fs::rename(tmp, target, ec);
  if (ec) fs::remove(tmp, ec);
}

}  // namespace varbo::detail
