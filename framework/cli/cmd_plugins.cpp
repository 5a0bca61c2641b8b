// `varbo plugins [--describe NAME]`: what is installed, with every option and its default.
#include <fmt/format.h>

#include <cstdio>
#include <filesystem>

#include "commands.hpp"
#include "varbo/errors.hpp"
#include "varbo/loader.hpp"
#include "varbo/study.hpp"
#include "varbo/text.hpp"

namespace varbo::cli {

static std::string default_text(const OptionSpec& s) {
  if (s.required) return "(required)";
  if (s.default_yaml.empty()) return "(unset)";
  return s.default_yaml;
}

static void print_options(const std::vector<OptionSpec>& options, const std::string& indent) {
  for (const auto& o : options)
    std::printf("%s%-22s %-14s default %-18s %s; expects %s\n", indent.c_str(), o.name.c_str(),
                type_name(o.type).c_str(), default_text(o).c_str(), o.description.c_str(), o.expected().c_str());
}

static void describe(const ComponentInfo& c) {
  std::printf("%s %s  (%s plugin %s, %s)\n  %s\n", kind_name(c.kind).c_str(), c.full_name().c_str(),
              is_builtin(c) ? "built-in" : "third-party", c.plugin.c_str(), c.library.c_str(),
              c.description.c_str());
  if (!c.provides.empty()) std::printf("  provides: %s\n", join(c.provides).c_str());
  if (!c.needs.empty()) std::printf("  needs:    %s\n", join(c.needs).c_str());
  if (c.options.empty()) {
    std::printf("  options: none\n");
  } else {
    std::printf("  options:\n");
    print_options(c.options, "    ");
  }
}

Runner add_plugins(CLI::App& app) {
  auto* cmd = app.add_subcommand("plugins", "List plugins and components with their options and defaults");
  struct Args {
    std::string describe;
    std::vector<std::string> load;
    bool brief = false;
    bool libraries = false;
  };
  auto a = std::make_shared<Args>();
  auto* describe_opt = cmd->add_option("--describe", a->describe, "show one component (name or plugin/name), or 'study' for top-level keys");
  cmd->add_option("--load", a->load, "also load these plugin files or folders (a file named must load; a folder's broken libraries are listed as skipped)");
  cmd->add_flag("--brief", a->brief, "names only");
  cmd->add_flag("--libraries", a->libraries,
                "only the plugin libraries, from their metadata sections: no plugin code runs (components are "
                "not listed)")
      ->excludes(describe_opt);
  return [a, describe_opt]() {
    Registry registry;
    PluginLoader loader(registry);
    for (const auto& p : a->load)
      if (std::error_code ec; !std::filesystem::exists(p, ec))
        throw InputError(fmt::format("--load {}: {}; expected a plugin file (libvarbo_NAME.so) or a folder of them",
                                     p, ec ? ec.message() : "does not exist"));
    if (describe_opt->count() > 0 && a->describe.empty())
      throw InputError("--describe: an empty name; expected a component name (e.g. ei, gp, plugin/name) or 'study'");
    loader.set_metadata_only(a->libraries);
    loader.load_default(a->load);  // built-ins first, so --load cannot replace them
    if (a->describe == "study") {
      std::printf("study file (top-level keys)\n");
      print_options(study_options(), "  ");
      return 0;
    }
    if (!a->describe.empty()) {
      // Resolve exactly as a config does (built-in first), and say what else carries the name.
      bool any = false;
      for (Kind k : {Kind::Task, Kind::Algorithm, Kind::Surrogate, Kind::Acquisition, Kind::Region, Kind::Sampler,
                     Kind::Optimizer, Kind::Kernel}) {
        const ComponentInfo* chosen = registry.try_find(k, a->describe);
        std::vector<const ComponentInfo*> same;
        for (const auto* c : registry.components(k))
          if (c != chosen && (c->name == a->describe || c->full_name() == a->describe)) same.push_back(c);
        if (chosen) {
          if (any) std::printf("\n");
          describe(*chosen);
          any = true;
          for (const auto* c : same)
            std::printf("  note: '%s' means this %s; %s plugin '%s' (%s) also has one, reachable only as '%s'\n",
                        a->describe.c_str(), is_builtin(*chosen) ? "built-in one" : "one",
                        is_builtin(*c) ? "the built-in" : "the third-party", c->plugin.c_str(),
                        c->library.c_str(), c->full_name().c_str());
        } else if (!same.empty()) {
          if (any) std::printf("\n");
          any = true;
          std::vector<std::string> full;
          for (const auto* c : same) full.push_back(c->full_name());
          std::printf("%s name '%s' is ambiguous (several third-party plugins, no built-in one); a config must "
                      "use one of: %s\n",
                      kind_name(k).c_str(), a->describe.c_str(), join(full).c_str());
          for (const auto* c : same) {
            std::printf("\n");
            describe(*c);
          }
        }
      }
      if (!any) {
        std::vector<std::string> names;
        for (const auto* c : registry.all()) names.push_back(c->name);
        const std::string near = closest_match(a->describe, names);
        throw UnknownComponentError(fmt::format("no component named '{}'. Known: {}{}", a->describe, join(names),
                                                near.empty() ? "" : "; did you mean '" + near + "'?"));
      }
      return 0;
    }
    std::printf("plugin libraries (%zu %s, %zu skipped)\n", loader.loaded().size(),
                a->libraries ? "found; metadata only, none loaded" : "loaded", loader.skipped().size());
    for (const auto& l : loader.loaded())
      std::printf("  %-22s %-8s %s%s\n", l.name.c_str(), l.version.c_str(), l.path.c_str(),
                  l.builtin ? "" : "  (third-party)");
    // printable(): the reason quotes a path from VARBO_PLUGIN_PATH, which may hold a newline or an escape.
    for (const auto& s : loader.skipped()) std::printf("  SKIPPED %s\n", printable(s.reason).c_str());
    if (a->libraries) {
      std::printf("\ndescriptions (from each library's .varbo_meta section)\n");
      for (const auto& l : loader.loaded()) std::printf("  %-22s %s\n", l.name.c_str(), l.description.c_str());
      return 0;
    }
    for (const auto* c : loader.shadowed())
      std::printf("  NOTE %s '%s' of plugin '%s' has a built-in name: reachable only as '%s'\n",
                  kind_name(c->kind).c_str(), c->name.c_str(), c->plugin.c_str(), c->full_name().c_str());
    for (Kind k : {Kind::Task, Kind::Algorithm, Kind::Surrogate, Kind::Acquisition, Kind::Region, Kind::Sampler,
                   Kind::Optimizer, Kind::Kernel}) {
      auto comps = registry.components(k);
      std::printf("\n%ss (%zu)\n", kind_name(k).c_str(), comps.size());
      for (const auto* c : comps) {
        std::printf("  %-28s %s\n", c->full_name().c_str(), c->description.c_str());
        if (!a->brief) print_options(c->options, "      ");
      }
    }
    std::printf("\nTop-level study keys: varbo plugins --describe study\n");
    return 0;
  };
}

}  // namespace varbo::cli
