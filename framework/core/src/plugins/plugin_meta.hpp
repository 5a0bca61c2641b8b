#pragma once
// Reads a plugin's ".varbo_meta" section (varbo/plugin.hpp) from the file, without loading it.
#include <optional>
#include <string>

#include "varbo/plugin.hpp"

namespace varbo::detail {

struct PluginMeta {
  varbo_plugin_meta block{};      ///< zero-filled past the section's end (a smaller, other-ABI block)
  std::uint64_t section_size = 0;
  /// The block has this host's layout (size) and its strings are NUL-terminated: the strings may be read.
  bool complete() const;
};

/// The metadata of `path`, a file that passed check_elf_file(); nullopt when the file has no ".varbo_meta"
/// section (not a varbo plugin, one of ABI 3 or older, or one whose section headers were stripped). Throws
/// PluginLoadError naming the file when the section is there but is no metadata block (too small for its
/// header, wrong magic, past the end of the file). Compare abi_version before trusting the rest.
std::optional<PluginMeta> read_plugin_meta(const std::string& path);

}  // namespace varbo::detail
