#pragma once
// An output file named on the command line (`export -o`, `plot -o`) must not be a study: a typo (`-o gait.db` for
// `-o gait.csv`) replaced the study file with a CSV and lost every trial, with exit 0 (session 20).
#include <fmt/format.h>

#include <cstring>
#include <fstream>
#include <string>

#include "varbo/errors.hpp"

namespace varbo::cli {

/// Throws InputError (exit 2) when `output` is a SQLite file (any study, this one or another), or a SQLite
/// journal beside one (`-wal`, `-shm`, `-journal`): writing there would destroy it.
inline void refuse_to_write_over_a_study(const std::string& output, const std::string& option) {
  const auto is_sqlite = [](const std::string& path) {
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
                                 "file (e.g. trials.csv, model.svg)",
                                 option, output, base != output ? "part of the" : "a"));
}

}  // namespace varbo::cli
