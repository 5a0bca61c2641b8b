#pragma once
// An output file named on the command line (`export -o`, `plot -o`) must not be a study: a typo (`-o gait.db` for
// `-o gait.csv`) replaced the study file with a CSV and lost every trial, with exit 0 (session 20).
#include <fmt/format.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <system_error>

#include "varbo/errors.hpp"

namespace varbo::cli {

/// Throws InputError (exit 2) when `output` is a SQLite file (any study, this one or another), or a SQLite
/// journal beside one (`-wal`, `-shm`, `-journal`): writing there would destroy it.
inline void refuse_to_write_over_a_study(const std::string& output, const std::string& option) {
  const auto is_sqlite = [](const std::string& path) {
    // Only a regular file can hold a study. Opening anything else to read its header blocked for good: `-o
    // /dev/stdout | head` opened the read end of varbo's own output pipe, a FIFO or a terminal waited for input
    // (red team, session 29).
    struct stat st {};
    if (::stat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) return false;
    std::ifstream in(path, std::ios::binary);
    char head[16] = {};
    return in.read(head, sizeof head) && std::memcmp(head, "SQLite format 3", 16) == 0;
  };
  std::string base = output;
  for (const char* suffix : {"-wal", "-shm", "-journal"}) {
    const std::size_t n = std::strlen(suffix);
    if (base.size() > n && base.compare(base.size() - n, n, suffix) == 0) {
      base.resize(base.size() - n);
      break;
    }
  }
  if (is_sqlite(output) || (base != output && is_sqlite(base)))
    throw InputError(fmt::format("{} {}: is {} study file; writing there would destroy its trials. Name another "
                                 "file (e.g. export.csv, model.svg)",
                                 option, output, base != output ? "part of the" : "a"));
}

/// Throws InputError (exit 2) when `output` names one of the files a run writes in its folder (trials.csv,
/// config.resolved.yaml, model.yaml, summary.json, log.txt) inside a run folder (one holding study.db or
/// config.resolved.yaml), following links: `export -o RUN/trials.csv` and `plot -o RUN/trials.csv` replaced the
/// run's record with exit 0, and select, plot and rescore refused the run afterwards (red team, session 34).
inline void refuse_to_write_over_a_run_file(const std::string& output, const std::string& option) {
  namespace fs = std::filesystem;
  static const char* const kRunFiles[] = {"trials.csv", "config.resolved.yaml", "model.yaml", "summary.json",
                                          "log.txt"};
  const auto check = [&](const fs::path& p) {
    const std::string name = p.filename().string();
    if (std::find_if(std::begin(kRunFiles), std::end(kRunFiles), [&](const char* f) { return name == f; }) ==
        std::end(kRunFiles))
      return;
    const fs::path dir = p.has_parent_path() ? p.parent_path() : fs::path(".");
    std::error_code ec;
    if (fs::exists(dir / "study.db", ec) || fs::exists(dir / "config.resolved.yaml", ec))
      throw InputError(fmt::format("{} {}: is the run folder {}'s own {}; writing there would replace the run's "
                                   "record. Name a file outside the run folder or with another name (e.g. "
                                   "export.csv, model.svg)",
                                   option, output, dir.string(), name));
  };
  check(fs::path(output));
  std::error_code ec;
  const fs::path real = fs::weakly_canonical(fs::path(output), ec);  // a link to a run's file
  if (!ec) check(real);
}

/// Whether `output` names standard output: "-", or a path to the very file it writes to (`/dev/stdout`,
/// `/proc/self/fd/1`). A command then writes its data there and prints nothing else: `plot -o /dev/stdout >
/// m.svg` printed the file's name over the SVG's first bytes (red team, session 29).
inline bool is_standard_output(const std::string& output) {
  if (output == "-") return true;
  struct stat named {}, out {};
  return ::stat(output.c_str(), &named) == 0 && ::fstat(STDOUT_FILENO, &out) == 0 && named.st_dev == out.st_dev &&
         named.st_ino == out.st_ino;
}

/// Writes `text` to the file `output` names, or to standard output for "-"; throws InputError on failure.
inline void write_output(const std::string& output, const std::string& text, const char* what) {
  if (output == "-") {
    std::fwrite(text.data(), 1, text.size(), stdout);  // main() checks the write of standard output
    return;
  }
  std::ofstream f(output, std::ios::trunc);
  if (!f) throw InputError(fmt::format("{}: cannot write {} ({})", output, what, std::strerror(errno)));
  errno = 0;
  f << text;
  f.close();  // the buffered tail is written here: `-o /dev/full` exited 0 with nothing written
  // The system's reason: "disk full?" was said of /proc/version too (audit, session 49).
  if (!f)
    throw InputError(fmt::format("{}: write failed ({})", output, errno != 0 ? std::strerror(errno) : "disk full?"));
}

}  // namespace varbo::cli
