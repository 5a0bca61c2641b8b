#pragma once
// Files a command reads (or appends to) by name: only a regular file, or a link to one. A FIFO blocked `select`,
// `plot` and `run --resume` forever, a directory ended in "internal error: basic_filebuf::underflow" (red team,
// session 34); /dev/zero would be read forever.
#include <optional>
#include <string>

namespace varbo {

/// What `path` is when it exists and is not a regular file (links are followed): "a directory", "a FIFO", "a socket",
/// "a block device", "a character device"; nullopt when it is a regular file or does not exist. The one test behind
/// the two below and the configuration loader's (which throws ConfigError).
std::optional<std::string> irregular_file_kind(const std::string& path);

/// Throws InputError "<path>: not a regular file (<what>, e.g. a directory or a FIFO)" when `path` exists and is
/// not a regular file (links are followed). Returns whether it exists.
bool require_regular_file(const std::string& path, const std::string& what);

/// The same test without throwing: true when `path` does not exist or is a regular file.
bool absent_or_regular_file(const std::string& path);

/// Like irregular_file_kind, of the name itself (lstat, links not followed): "a symbolic link" too. For files a
/// library opens by a name derived from another (SQLite's journal beside a study), where a planted link or FIFO
/// must be refused before the library blocks in open() or writes through it (red team, session 37).
std::optional<std::string> irregular_entry_kind(const std::string& path);

}  // namespace varbo
