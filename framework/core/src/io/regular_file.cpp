#include "varbo/regular_file.hpp"

#include <fmt/format.h>

#include <filesystem>
#include <system_error>

#include "varbo/errors.hpp"

namespace varbo {
namespace {
const char* kind(std::filesystem::file_type t) {
  switch (t) {
    case std::filesystem::file_type::directory: return "a directory";
    case std::filesystem::file_type::fifo: return "a FIFO";
    case std::filesystem::file_type::socket: return "a socket";
    case std::filesystem::file_type::block: return "a block device";
    case std::filesystem::file_type::character: return "a character device";
    case std::filesystem::file_type::symlink: return "a symbolic link";
    default: return "not a regular file";
  }
}
}  // namespace

std::optional<std::string> irregular_file_kind(const std::string& path) {
  std::error_code ec;
  const auto st = std::filesystem::status(path, ec);
  if (ec || !std::filesystem::exists(st) || std::filesystem::is_regular_file(st)) return std::nullopt;
  return std::string(kind(st.type()));
}

bool absent_or_regular_file(const std::string& path) { return !irregular_file_kind(path); }

std::optional<std::string> irregular_entry_kind(const std::string& path) {
  std::error_code ec;
  const auto st = std::filesystem::symlink_status(path, ec);
  if (ec || !std::filesystem::exists(st) || std::filesystem::is_regular_file(st)) return std::nullopt;
  return std::string(kind(st.type()));
}

bool require_regular_file(const std::string& path, const std::string& what) {
  if (const auto k = irregular_file_kind(path))
    throw InputError(fmt::format("{}: not a regular file ({}; expected {})", path, *k, what));
  std::error_code ec;
  return std::filesystem::exists(path, ec);
}

}  // namespace varbo
