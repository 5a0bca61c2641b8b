#pragma once
// Plugins loaded on demand (PluginLoader::set_on_demand): the loader registers, per Registry, a function that
// loads the libraries providing a component name; the registry calls it before each lookup ("" before a listing
// and when a name is still unknown), so every lookup resolves as with every plugin loaded. Kept beside the
// Registry, not in it, so that registry.hpp — which every plugin compiles against — is unchanged.
#include <functional>
#include <string>

#include "varbo/registry.hpp"

namespace varbo::detail {

using DemandFn = std::function<void(const std::string& name)>;

/// Installs (or, with an empty function, removes) the on-demand loader of `registry`.
void set_on_demand(const Registry& registry, DemandFn load);
/// Calls the on-demand loader of `registry`, if any, with `name`; false when there is none.
bool demand(const Registry& registry, const std::string& name);

}  // namespace varbo::detail
