#pragma once
// A third-party library is first loaded in a child process: damage that the file checks before dlopen cannot see
// (a relocation or symbol table entry overwritten, static initializers that crash) killed every varbo command
// with SIGSEGV, or ld.so's "Inconsistency detected" assertion (exit 127), even a run that used none of its
// components (red team, session 34). Only the child dies then, and the library is skipped with its reason.
#include <functional>
#include <optional>
#include <string>

namespace varbo::detail {

/// Forks; the child dlopens `path` as the loader would (RTLD_NOW | RTLD_LOCAL), runs `in_child` on the handle
/// (the plugin's registration, into the child's copy of the registry) and exits. Returns why loading it is not
/// safe — the child was killed by a signal or ended otherwise than by returning — or nullopt when the child
/// returned, also when dlopen failed cleanly (the caller's own dlopen then says why) or the child could not be
/// started or did not end within `seconds` (a lock another thread held at the fork: no verdict, load as before).
std::optional<std::string> load_crashes(const std::string& path, const std::function<void(void*)>& in_child,
                                        double seconds = 20);

}  // namespace varbo::detail
