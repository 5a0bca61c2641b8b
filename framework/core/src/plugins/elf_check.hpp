#pragma once
// Checks that a file is a complete ELF shared library for this machine before dlopen maps it.
#include <string>

namespace varbo::detail {

/// Throws PluginLoadError naming `path` when the file is not a regular file, not ELF, built for another
/// architecture, byte order or word size, not a shared object, or truncated (a program header, segment or
/// the section header table reaching past the end of the file). dlopen maps segments without looking at the
/// file's size, so a truncated library otherwise kills the process with SIGBUS on first touch.
void check_elf_file(const std::string& path);

/// "x86-64", "aarch64", ... for an ELF e_machine value ("machine 1234" when unknown).
std::string elf_machine_name(unsigned machine);

}  // namespace varbo::detail
