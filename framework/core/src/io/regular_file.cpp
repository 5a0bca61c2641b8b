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
    default: return "not a regular file";
  }
}
}  // namespace

bool absent_or_regular_file(const std::string& path) {
  std::error_code ec;
  const auto st = std::filesystem::status(path, ec);
  return ec || !std::filesystem::exists(st) || std::filesystem::is_regular_file(st);
}

bool require_regular_file(const std::string& path, const std::string& what) {
  std::error_code ec;
  const auto st = std::filesystem::status(path, ec);
  if (ec || !std::filesystem::exists(st)) return false;
  if (!std::filesystem::is_regular_file(st))
    throw InputError(fmt::format("{}: not a regular file ({}; expected {})", path, kind(st.type()), what));
  return true;
}

}  // namespace varbo
