// Plugin loading: good, broken, foreign and mismatched libraries each give a clear, file-naming error.
#include <elf.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <algorithm>
#include <chrono>
#include <map>

#include "../../framework/core/src/plugins/plugin_index.hpp"  // the index format (internal to the loader)
#include "varbo/errors.hpp"
#include "varbo/loader.hpp"
#include "varbo/log.hpp"
#include "varbo/plugin.hpp"
#include "varbo/study.hpp"
#include "varbo/study_api.hpp"
#include "study_helpers.hpp"
#include "varbo_test.hpp"

using namespace varbo;
namespace fs = std::filesystem;

namespace {
std::string fixture(const std::string& name) { return std::string(VARBO_FIXTURE_DIR) + "/libvarbo_fixture_" + name + ".so"; }

template <class E>
std::string error_loading(const std::string& path) {
  Registry r;
  PluginLoader l(r);
  try {
    l.load_file(path);
  } catch (const E& e) {
    return e.what();
  }
  return "(no error)";
}
bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }
std::vector<char> read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}
/// Writes `bytes` to a file in the temporary folder and returns its path.
std::string scratch(const std::string& name, const std::vector<char>& bytes) {
  const std::string path = (fs::temp_directory_path() / name).string();
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  return path;
}
}  // namespace

TEST_CASE("a good plugin registers its components and reports its info") {
  Registry r;
  PluginLoader l(r);
  l.load_file(fixture("good"));
  REQUIRE(l.loaded().size() == 1);
  CHECK(l.loaded()[0].name == "fixture");
  CHECK(l.loaded()[0].version == "9.9.9");
  CHECK(l.loaded()[0].fingerprint == host_fingerprint());
  const ComponentInfo& c = r.find(Kind::Acquisition, "fixture/fixture_constant");
  CHECK(c.library == fixture("good"));
  auto a = r.create<Acquisition>("fixture_constant", BuildContext{});
  CHECK(a->evaluate(Vec::Zero(2), nullptr) == 42.0);
}

TEST_CASE("a plugin factory throwing a standard exception is a config error naming the component and file") {
  Registry r;
  PluginLoader l(r);
  l.load_file(fixture("good"));
  std::string m = "(no error)";
  try {
    r.create<Acquisition>(r.resolve(Kind::Acquisition, ConfigNode::parse("acquisition: {type: fixture_refusing, weight: 2}\n",
                                                                         "/tmp/s.yaml").child("acquisition")),
                          BuildContext{});
  } catch (const ConfigError& e) {
    m = e.what();
  }
  CHECK(contains(m, "/tmp/s.yaml:1:14: key 'acquisition': acquisition 'fixture/fixture_refusing'"));
  CHECK(contains(m, "(from " + fixture("good") + ")"));
  CHECK(contains(m, "could not be created: weight must be positive, got 2"));
}

TEST_CASE("an ABI mismatch names the file and both versions") {
  const std::string m = error_loading<PluginVersionError>(fixture("abi"));
  CHECK(contains(m, fixture("abi")));
  CHECK(contains(m, "built for plugin ABI 999, host is ABI " + std::to_string(VARBO_ABI_VERSION)));
}

TEST_CASE("a build-fingerprint mismatch shows what the plugin was built with and what the host is") {
  const std::string m = error_loading<PluginVersionError>(fixture("build"));
  CHECK(contains(m, fixture("build")));
  CHECK(contains(m, "built with [abi=1 compiler=othercc-99"));
  CHECK(contains(m, std::string("host is [") + host_fingerprint() + "]"));
}

TEST_CASE("a foreign shared library is not a varbo plugin") {
  const std::string m = error_loading<PluginLoadError>(fixture("foreign"));
  CHECK(contains(m, fixture("foreign")));
  CHECK(contains(m, "not a varbo plugin"));
}

TEST_CASE("a text file is not a shared library") {
  const std::string m = error_loading<PluginLoadError>(fixture("text"));
  CHECK(m == fixture("text") + ": not a shared library (no ELF header)");
}

TEST_CASE("a truncated library is refused before dlopen maps it (no SIGBUS)") {
  const std::vector<char> good = read_bytes(fixture("good"));
  // Cut inside the ELF header, inside the program headers, inside the segments and one byte short.
  for (std::size_t cut : {std::size_t{40}, std::size_t{200}, good.size() / 3, good.size() / 2, good.size() - 1}) {
    CAPTURE(cut);
    const std::string trunc = scratch("libvarbo_truncated_test.so", {good.begin(), good.begin() + long(cut)});
    const std::string m = error_loading<PluginLoadError>(trunc);
    CHECK(contains(m, trunc + ": truncated"));
  }
}

TEST_CASE("a library for another architecture or word size says what it was built for") {
  std::vector<char> bytes = read_bytes(fixture("good"));
#if defined(__x86_64__)
  bytes[18] = char(EM_AARCH64 & 0xff);
  bytes[19] = char(EM_AARCH64 >> 8);
  CHECK(contains(error_loading<PluginLoadError>(scratch("libvarbo_arch.so", bytes)),
                 "built for aarch64, this is x86-64 (64-bit); rebuild the plugin for this machine"));
  bytes = read_bytes(fixture("good"));
  bytes[EI_CLASS] = ELFCLASS32;
  bytes[18] = char(EM_386);
  bytes[19] = 0;
  CHECK(contains(error_loading<PluginLoadError>(scratch("libvarbo_arch.so", bytes)),
                 "built for i386 (32-bit), this is x86-64 (64-bit)"));
#endif
  bytes = read_bytes(fixture("good"));
  bytes[EI_DATA] = ELFDATA2MSB;
  CHECK(contains(error_loading<PluginLoadError>(scratch("libvarbo_arch.so", bytes)), "big-endian byte order"));
  bytes = read_bytes(fixture("good"));
  bytes[16] = char(ET_EXEC);
  CHECK(contains(error_loading<PluginLoadError>(scratch("libvarbo_arch.so", bytes)),
                 "not a shared library (ELF type executable"));
}

TEST_CASE("a section header table past the end of the file is refused") {
  std::vector<char> bytes = read_bytes(fixture("good"));
  Elf64_Ehdr eh;
  std::memcpy(&eh, bytes.data(), sizeof eh);
  eh.e_shoff = bytes.size() - 10;
  std::memcpy(bytes.data(), &eh, sizeof eh);
  CHECK(contains(error_loading<PluginLoadError>(scratch("libvarbo_sh.so", bytes)),
                 "the section header table (offset"));
}

TEST_CASE("a plugin whose metadata gives an empty name is refused with the file named") {
  const std::string m = error_loading<PluginLoadError>(fixture("emptyname"));
  CHECK(m == fixture("emptyname") + ": not loaded: its plugin info gives an empty name (VARBO_PLUGIN(\"name\", ...) "
             "names it)");
}

TEST_CASE("a plugin built for another ABI or build is refused from its metadata and runs none of its code") {
  // Every fixture's static initializer sets this variable when dlopen runs it.
  unsetenv("VARBO_FIXTURE_STATIC_INIT_RAN");
  CHECK(contains(error_loading<PluginVersionError>(fixture("abi")), "built for plugin ABI 999"));
  CHECK(contains(error_loading<PluginVersionError>(fixture("build")), "built with [abi=1 compiler=othercc-99"));
  CHECK(contains(error_loading<PluginLoadError>(fixture("emptyname")), "empty name"));
  CHECK(std::getenv("VARBO_FIXTURE_STATIC_INIT_RAN") == nullptr);
  // The check is not vacuous: loading a good plugin does run its initializers (a fresh copy: dlopen runs
  // them once per library, and other tests load the fixture itself).
  const std::string copy = scratch("libvarbo_fixture_copy_static_init.so", read_bytes(fixture("good")));
  Registry r;
  PluginLoader l(r);
  l.load_file(copy);
  REQUIRE(std::getenv("VARBO_FIXTURE_STATIC_INIT_RAN") != nullptr);
  CHECK(std::string(std::getenv("VARBO_FIXTURE_STATIC_INIT_RAN")) == "fixture+");
}

TEST_CASE("a metadata-only scan lists plugins without running any of their code") {
  unsetenv("VARBO_FIXTURE_STATIC_INIT_RAN");
  const std::string copy = scratch("libvarbo_fixture_copy_metadata_only.so", read_bytes(fixture("good")));
  Registry r;
  PluginLoader l(r);
  l.set_metadata_only(true);
  l.load_file(copy);
  REQUIRE(l.loaded().size() == 1);
  CHECK(l.loaded()[0].name == "fixture");
  CHECK(l.loaded()[0].version == "9.9.9");
  CHECK(l.loaded()[0].fingerprint == host_fingerprint());
  CHECK(r.all().empty());  // nothing registered
  CHECK(std::getenv("VARBO_FIXTURE_STATIC_INIT_RAN") == nullptr);
  CHECK(contains(error_loading<PluginVersionError>(fixture("abi")), "built for plugin ABI 999"));
}

TEST_CASE("the metadata section is read from the file and matches what the plugin reports") {
  Registry r;
  PluginLoader l(r);
  l.load_file(fixture("good"));
  REQUIRE(l.loaded().size() == 1);
  CHECK(l.loaded()[0].description == "loader test fixture");
  // A corrupt magic in the section is refused before dlopen, naming the file and the section.
  std::vector<char> bytes = read_bytes(fixture("good"));
  const std::string magic = VARBO_PLUGIN_META_MAGIC;
  auto at = std::search(bytes.begin(), bytes.end(), magic.begin(), magic.end());
  REQUIRE(at != bytes.end());
  *at = 'X';
  const std::string bad = scratch("libvarbo_badmeta.so", bytes);
  CHECK(contains(error_loading<PluginLoadError>(bad), bad + ": malformed plugin metadata (.varbo_meta section): "
                                                           "wrong magic bytes"));
}

TEST_CASE("a plugin cannot register under another plugin's name") {
  Registry r;
  PluginLoader l(r);
  l.load_file(fixture("good"));
  const ComponentInfo& c = r.find(Kind::Acquisition, "fixture_impostor");
  CHECK(c.plugin == "fixture");
  CHECK(c.library == fixture("good"));
  CHECK(r.try_find(Kind::Acquisition, "acquisitions/fixture_impostor") == nullptr);
}

TEST_CASE("a plugin name with the qualification separator is refused") {
  CHECK(contains(error_loading<PluginLoadError>(fixture("slashname")),
                 ": not loaded: its plugin name 'bad/name' has a character other than ASCII letters, digits"));
}

TEST_CASE("hostile entries in a plugin folder are skipped with a named reason, never thrown") {
  const fs::path dir = fs::temp_directory_path() / "varbo_hostile_plugin_dir";
  fs::remove_all(dir);
  fs::create_directories(dir / "libvarbo_dir.so");
  fs::create_symlink("libvarbo_loop_b.so", dir / "libvarbo_loop_a.so");
  fs::create_symlink("libvarbo_loop_a.so", dir / "libvarbo_loop_b.so");
  fs::create_symlink("libvarbo_nowhere.so", dir / "libvarbo_dangling.so");
  REQUIRE(mkfifo((dir / "libvarbo_fifo.so").c_str(), 0600) == 0);  // opening it for reading would block
  fs::copy_file(fixture("good"), dir / "libvarbo_good.so");
  Registry r;
  PluginLoader l(r);
  l.load_directory(dir.string());
  CHECK(l.loaded().size() == 1);
  REQUIRE(l.skipped().size() == 5);
  std::map<std::string, std::string> why;
  for (const auto& s : l.skipped()) why[fs::path(s.path).filename().string()] = s.reason;
  CHECK(contains(why["libvarbo_dangling.so"], "broken symbolic link"));
  CHECK(contains(why["libvarbo_dir.so"], "a directory, not a shared library file"));
  CHECK(contains(why["libvarbo_fifo.so"], "a named pipe (FIFO)"));
  CHECK(contains(why["libvarbo_loop_a.so"], "symbolic link loop"));
  CHECK(contains(why["libvarbo_loop_b.so"], (dir / "libvarbo_loop_b.so").string() + ": symbolic link loop"));
  // The same folder named as an extra path, and a symlink loop as the path itself: warnings, no exception.
  fs::create_symlink("loop2", dir / "loop1");
  fs::create_symlink("loop1", dir / "loop2");
  Registry r2;
  PluginLoader l2(r2);
  CHECK_NOTHROW(l2.load_default({dir.string(), (dir / "loop1").string()}));
  bool loop_named = false;
  for (const auto& s : l2.skipped()) loop_named |= contains(s.reason, (dir / "loop1").string());
  CHECK(loop_named);
  fs::remove_all(dir);
}

TEST_CASE("missing plugin paths, from the caller or VARBO_PLUGIN_PATH, are named") {
  ::setenv("VARBO_PLUGIN_PATH", "/nonexistent_env_dir", 1);
  Registry r;
  PluginLoader l(r);
  l.load_default({"/nonexistent_extra_dir"});
  ::unsetenv("VARBO_PLUGIN_PATH");
  std::string all;
  for (const auto& s : l.skipped()) all += s.reason + "\n";
  CHECK(contains(all, "/nonexistent_extra_dir: plugin path from plugin_path or --load: does not exist"));
  CHECK(contains(all, "/nonexistent_env_dir: plugin path from VARBO_PLUGIN_PATH: does not exist"));
  CHECK_FALSE(r.all().empty());  // the built-ins still load
}

TEST_CASE("plugin_path naming nothing is a config error at its key") {
  auto error_of = [](const std::string& yaml) {
    try {
      plugin_paths_of(ConfigNode::parse(yaml, "/tmp/s.yaml"));
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  const std::string a = error_of("task: branin\nplugin_path: [/nonexistent]\n");
  CHECK(contains(a, "/tmp/s.yaml:2:15: key 'plugin_path[0]'"));
  CHECK(contains(a, "plugin path '/nonexistent' does not exist; expected a plugin file (libvarbo_NAME.so)"));
  const std::string b = error_of("task: branin\nplugin_path: 5\n");
  CHECK(contains(b, "/tmp/s.yaml:2:14: key 'plugin_path': plugin path '5' (/tmp/5) does not exist"));
  CHECK(contains(error_of("plugin_path: {a: 1}\n"), "expected a plugin file"));
  CHECK(plugin_paths_of(ConfigNode::parse("plugin_path: [" + std::string(VARBO_FIXTURE_DIR) + "]\n", "/tmp/s.yaml"))
            .size() == 1);
}

TEST_CASE("a third-party component with a built-in name is reachable only by its full name") {
  Registry r;
  PluginLoader l(r);
  l.load_default({fixture("clash")});
  const ComponentInfo& ei = r.find(Kind::Acquisition, "ei");
  CHECK(ei.plugin == "acquisitions");
  CHECK(is_builtin(ei));
  const ComponentInfo& theirs = r.find(Kind::Acquisition, "thirdparty/ei");
  CHECK(theirs.library == fixture("clash"));
  CHECK_FALSE(is_builtin(theirs));
  REQUIRE(l.shadowed().size() == 1);
  CHECK(l.shadowed()[0] == &theirs);
  // A unique third-party name still resolves by its short name.
  CHECK(r.find(Kind::Acquisition, "thirdparty_constant").plugin == "thirdparty");
  // The default acquisition of a BO config is the built-in one.
  auto a = r.create<Acquisition>("{type: thirdparty/ei}", BuildContext{});
  CHECK(a->evaluate(Vec::Zero(2), nullptr) == 42.0);
}

TEST_CASE("a plugin whose registration throws reports the reason") {
  const std::string m = error_loading<PluginLoadError>(fixture("throws"));
  CHECK(contains(m, "failed to register: fixture refuses to register"));
}

TEST_CASE("a plugin whose registration fails part-way leaves none of its components") {
  Registry r;
  PluginLoader l(r);
  try {
    l.load_file(fixture("half"));
    FAIL("loaded");
  } catch (const PluginLoadError& e) {
    CHECK(contains(e.what(), "failed to register: fails after one component"));
  }
  // Before: reported as skipped, yet `acquisition: fixture_half` ran.
  CHECK(r.try_find(Kind::Acquisition, "fixture_half") == nullptr);
  CHECK(l.loaded().empty());
}

TEST_CASE("a registration that throws something other than a std::exception is a load error, not a crash") {
  const std::string m = error_loading<PluginLoadError>(fixture("intthrow"));
  CHECK(contains(m, "failed to register: it threw something that is not a std::exception"));
}

TEST_CASE("a third-party library that crashes while loading is refused; only a test process dies") {
  // load_probe.hpp: damaged relocations or a crashing static initializer killed every command with SIGSEGV (red
  // team, session 34). The library is first loaded in a child process.
  for (const char* which : {"crashinit", "crashreg"}) {
    CAPTURE(which);
    Registry r;
    PluginLoader l(r);
    try {
      l.load_file(fixture(which));
      FAIL("loaded");
    } catch (const PluginLoadError& e) {
      CHECK(contains(e.what(), fixture(which)));
      CHECK(contains(e.what(), "signal 11 (SIGSEGV)"));
    }
    CHECK(l.loaded().empty());
    CHECK(r.try_find(Kind::Acquisition, "fixture_constant") == nullptr);
  }
  // In a folder it is skipped with that reason; the folder's good library still loads.
  const fs::path dir = fs::temp_directory_path() / ("varbo_crash_folder_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  fs::copy_file(fixture("good"), dir / "libvarbo_fixture_good.so");
  fs::copy_file(fixture("crashinit"), dir / "libvarbo_fixture_zcrash.so");
  Registry r;
  PluginLoader l(r);
  l.load_directory(dir.string());
  CHECK(l.loaded().size() == 1);
  REQUIRE(l.skipped().size() == 1);
  CHECK(contains(l.skipped()[0].reason, "SIGSEGV"));
  fs::remove_all(dir);
}

TEST_CASE("option declarations are checked when the plugin loads") {
  // An option named `type` was written beside the component's `type:` into config.resolved.yaml and the stored
  // study, which then no longer parsed ("duplicate key 'type'").
  CHECK(contains(error_loading<PluginLoadError>(fixture("typeopt")), "declares an option named 'type'"));
  CHECK(contains(error_loading<PluginLoadError>(fixture("optdup")), "declares the option 'w' twice"));
  Registry r;
  auto info = make_component<Acquisition>("my acq/v2", "", {}, Factory<Acquisition>([](const Options&, const BuildContext&) {
                                            return std::unique_ptr<Acquisition>();
                                          }));
  CHECK_THROWS_WITH_AS(r.add(info), doctest::Contains("character other than ASCII letters"), PluginLoadError);
}

TEST_CASE("an option whose declared default fails its own declaration is a load error naming it") {
  // Accepted before: a default outside its range or choices was reported at the user's configuration, which never
  // named the option, and a default that is not YAML ended every run using the component in "internal error"
  // (red team, session 26).
  const auto with = [](OptionSpec spec) {
    return make_component<Acquisition>("bad_default", "", {std::move(spec)},
                                       Factory<Acquisition>([](const Options&, const BuildContext&) {
                                         return std::unique_ptr<Acquisition>();
                                       }));
  };
  const std::vector<std::pair<OptionSpec, std::string>> bad = {
      {opt::node("n", "{a: [", ""), "its default '{a: [' is not YAML"},
      {opt::choice("c", "zz", {"a", "b"}, ""), "its default zz is not one of: a, b"},
      {opt::real("w", -1, "").at_least(0), "its default -1 is not"},
      {opt::integer("k", 3, "").at_most(2), "its default 3 is not"},
      {opt::reals("r", "[1, x]", ""), "its default [1, x] is not"},
  };
  for (const auto& [spec, message] : bad) {
    CAPTURE(spec.name);
    Registry r;
    const std::string expected = "acquisition 'bad_default' declares the option '" + spec.name + "': " + message;
    CHECK_THROWS_WITH_AS(r.add(with(spec)), doctest::Contains(expected.c_str()), PluginLoadError);
  }
  Registry r;
  CHECK_NOTHROW(r.add(with(opt::real("w", 0, "").at_least(0))));
}

TEST_CASE("only varbo's own libraries in the built-in folder are built-in") {
  // A third-party plugin installed into lib/varbo/plugins (where the SDK's RPATH points) counted as built-in:
  // its `ei` made every default `acquisition: ei` ambiguous.
  const std::string dir = PluginLoader::builtin_path().front();
  ComponentInfo own, theirs, elsewhere;
  own.library = dir + "/libvarbo_acquisitions.so";
  theirs.library = dir + "/libvarbo_thirdparty.so";
  elsewhere.library = std::string(VARBO_FIXTURE_DIR) + "/libvarbo_acquisitions.so";
  CHECK(is_builtin(own));
  CHECK_FALSE(is_builtin(theirs));
  CHECK_FALSE(is_builtin(elsewhere));
}

TEST_CASE("exceptions and bad points from a third-party algorithm are named, not internal errors") {
  Registry r;
  PluginLoader l(r);
  l.load_default({fixture("good")});
  auto ask_with = [&](const std::string& mode) -> std::string {
    const std::string folder = test::temp_folder("loader_misbehaving_" + mode);
    const StudyConfig cfg = parse_study(
        ConfigNode::parse("task: branin\nbudget: 4\nalgorithm: {type: fixture_misbehaving, mode: " + mode + "}\n",
                          "<test>"),
        r);
    Study s = Study::attach(folder + "/s.db", cfg, r);
    try {
      s.ask();
    } catch (const PluginCodeError& e) {
      CHECK(s.store().trials().empty());  // nothing stored
      return e.what();
    }
    return "(no error)";
  };
  // Before: "internal error: fixture: ask exploded" (exit 3), naming no plugin; `throw 42` ended the process.
  const std::string thrown = ask_with("throw");
  CHECK(contains(thrown, "asking algorithm 'fixture/fixture_misbehaving'"));
  CHECK(contains(thrown, "fixture: ask exploded"));
  CHECK(contains(thrown, "third-party plugins loaded are: fixture (" + fixture("good") + ")"));
  CHECK(contains(ask_with("throw_int"), "not a std::exception"));
  // Before: the extra point became a stray pending trial; the NaN reached the task and failed in the store.
  CHECK(contains(ask_with("too_many"), "returned 2 points when asked for 1"));
  CHECK(contains(ask_with("nan"), "non-finite coordinate"));
}

TEST_CASE("a missing file is named") {
  CHECK(error_loading<PluginLoadError>("/nonexistent/libvarbo_x.so") ==
        "/nonexistent/libvarbo_x.so: plugin library not found");
}

TEST_CASE("scanning a folder loads the good library once and records every bad one") {
  Registry r;
  PluginLoader l(r);
  l.load_directory(VARBO_FIXTURE_DIR);
  // Sorted: abi, build, clash, crashinit, crashreg, emptyname, foreign, good, slashname, text, throws. clash and
  // good load; "throws" carries the same plugin name as good, so it is shadowed (first wins) and never runs;
  // eight are skipped (the two that crash in a test process among them).
  CHECK(l.loaded().size() == 2);
  CHECK(l.skipped().size() == 8);
  for (const auto& s : l.skipped()) CHECK(contains(s.reason, s.path));
}

TEST_CASE("the build tree's plugins are found next to libvarbo_core") {
  Registry& r = test::registry();
  CHECK_FALSE(r.all().empty());
  CHECK(default_loader().skipped().empty());
  try {
    r.find(Kind::Algorithm, "bayes");
    FAIL("expected UnknownComponentError");
  } catch (const UnknownComponentError& e) {
    CHECK(contains(e.what(), "unknown algorithm 'bayes'. Known: "));
    CHECK(contains(e.what(), "bo"));
  }
}

namespace {
/// The names of every component of `r`, for comparing two registries.
std::vector<std::string> component_names(const Registry& r) {
  std::vector<std::string> out;
  for (const ComponentInfo* c : r.all()) out.push_back(kind_name(c->kind) + " " + c->full_name() + " " + c->library);
  return out;
}
}  // namespace

TEST_CASE("plugins on demand: only the libraries a lookup needs are loaded; lookups and listings as with all") {
  Registry all;
  PluginLoader eager(all);
  eager.load_default();  // loads the built-in folder in full, and indexes it (varbo_plugins.index)
  REQUIRE(eager.loaded().size() > 3);
  for (const auto& dir : PluginLoader::builtin_path())
    if (fs::is_directory(dir)) CHECK(fs::exists(fs::path(dir) / "varbo_plugins.index"));

  Registry lazy;
  PluginLoader l(lazy);
  l.set_on_demand(true);
  l.load_default();
  CHECK(l.loaded().empty());  // nothing until a name is looked up
  const ComponentInfo& bo = lazy.find(Kind::Algorithm, "bo");
  CHECK(bo.library == all.find(Kind::Algorithm, "bo").library);
  CHECK(is_builtin(bo));
  REQUIRE(l.loaded().size() == 1);  // bo's library, and no other
  CHECK(l.loaded()[0].path == bo.library);
  // A full name "plugin/name" loads that plugin.
  const ComponentInfo& ei = all.find(Kind::Acquisition, "ei");
  CHECK(lazy.find(Kind::Acquisition, ei.full_name()).library == ei.library);
  CHECK(l.loaded().size() == 2);
  // An unknown name loads everything, so that the error lists every known component.
  std::string lazy_error, eager_error;
  try {
    lazy.find(Kind::Algorithm, "bayes");
  } catch (const UnknownComponentError& e) {
    lazy_error = e.what();
  }
  try {
    all.find(Kind::Algorithm, "bayes");
  } catch (const UnknownComponentError& e) {
    eager_error = e.what();
  }
  CHECK(!lazy_error.empty());
  CHECK(lazy_error == eager_error);
  CHECK(l.loaded().size() == eager.loaded().size());
  CHECK(component_names(lazy) == component_names(all));
}

TEST_CASE("plugins on demand: a listing loads everything; a third-party short name keeps meaning the built-in") {
  {
    Registry all;
    PluginLoader(all).load_default();  // make sure the built-in folder is indexed
  }
  Registry lazy;
  PluginLoader l(lazy);
  l.set_on_demand(true);
  l.load_default({fixture("clash")});
  // The clash fixture registers "ei": the built-in ei is loaded with it, and wins the short name.
  REQUIRE(l.shadowed().size() == 1);
  CHECK(lazy.find(Kind::Acquisition, "ei").plugin == "acquisitions");
  CHECK(lazy.find(Kind::Acquisition, "thirdparty/ei").library == fixture("clash"));
  const std::size_t before = l.loaded().size();
  CHECK(before < 5);
  CHECK_FALSE(lazy.components(Kind::Algorithm).empty());
  CHECK(l.loaded().size() > before);
}

TEST_CASE("a plugin index is trusted only while every library in its folder is as it recorded") {
  const fs::path dir = fs::temp_directory_path() / ("varbo_index_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  fs::copy_file(fixture("good"), dir / "libvarbo_a.so");
  fs::copy_file(fixture("clash"), dir / "libvarbo_b.so");
  CHECK_FALSE(detail::read_plugin_index(dir.string()));  // none yet
  auto files = detail::list_plugin_files(dir.string());
  REQUIRE(files);
  REQUIRE(files->size() == 2);
  (*files)[0].plugin = "fixture";
  (*files)[0].components = {"fixture_algorithm", "fixture_kernel"};
  (*files)[1].plugin = "thirdparty";
  (*files)[1].components = {"ei"};
  detail::write_plugin_index(dir.string(), *files);
  const auto index = detail::read_plugin_index(dir.string());
  REQUIRE(index);
  REQUIRE(index->size() == 2);
  CHECK((*index)[0].file == "libvarbo_a.so");
  CHECK((*index)[0].components == (*files)[0].components);
  CHECK((*index)[1].plugin == "thirdparty");
  // A rebuilt library (another modification time), an added one, a removed one: stale.
  const auto t = fs::last_write_time(dir / "libvarbo_b.so");
  fs::last_write_time(dir / "libvarbo_b.so", t + std::chrono::seconds(1));
  CHECK_FALSE(detail::read_plugin_index(dir.string()));
  fs::last_write_time(dir / "libvarbo_b.so", t);
  CHECK(detail::read_plugin_index(dir.string()));
  fs::copy_file(fixture("good"), dir / "libvarbo_c.so");
  CHECK_FALSE(detail::read_plugin_index(dir.string()));
  fs::remove(dir / "libvarbo_c.so");
  fs::remove(dir / "libvarbo_a.so");
  CHECK_FALSE(detail::read_plugin_index(dir.string()));
  fs::remove_all(dir);
}

TEST_CASE("a project moved with its run folder and plugins resumes with the plugins where they are now") {
  // A relative `plugin_path` used to be stored as the absolute path of its day: after the project folder was moved
  // (or copied to the lab's machine), `--resume` warned "does not exist; ignored" and then refused the study
  // ("unknown acquisition 'fixture_constant'"), and Study::open did the same.
  const fs::path root = test::temp_folder("loader_moved_project");
  const fs::path before = root / "before", after = root / "after";
  fs::create_directories(before / "plugins");
  fs::copy_file(fixture("good"), before / "plugins" / "libvarbo_fixture_good.so");
  {
    std::ofstream(before / "study.yaml") << "task: {type: branin}\nbudget: 6\nseed: 1\nthreads: 1\n"
                                            "plugin_path: [plugins]\n"
                                            "algorithm: {type: bo, initial_points: 3, acquisition: fixture_constant}\n";
  }
  RunOverrides ov;
  ov.output = (before / "runs" / "a").string();
  ov.budget = 4;
  ov.progress = false;
  CHECK(run_study_file((before / "study.yaml").string(), ov).evaluations == 4);
  {
    Study s = Study::create((before / "st.db").string(), (before / "study.yaml").string());
    const auto t = s.ask(1);
    REQUIRE(t.size() == 1);
    s.tell(t[0].id, 1.0);
  }
  fs::rename(before, after);
  RunOverrides resume;
  resume.progress = false;
  resume.budget = 6;
  const RunSummary r = resume_study((after / "runs" / "a").string(), resume);
  CHECK(r.evaluations == 6);
  Study s = Study::open((after / "st.db").string());
  CHECK(s.ask(1).size() == 1);  // the acquisition fixture_constant is found again

  // A copy next to the original loads the copy's plugins, not the original's: with the original's plugin replaced
  // by a file that cannot load (removed first: the process still maps the old one), the copy still opens and asks.
  const fs::path copy = root / "copy";
  fs::copy(after, copy, fs::copy_options::recursive);
  fs::remove(after / "plugins" / "libvarbo_fixture_good.so");
  std::ofstream(after / "plugins" / "libvarbo_fixture_good.so") << "rebuilt badly\n";
  CHECK(Study::open((copy / "st.db").string()).ask(1).size() == 1);
  CHECK_THROWS(Study::open((after / "st.db").string()));
}

TEST_CASE("a study's stored plugin folder that another user owns or every user can write is not loaded by reading") {
  // Red team, session 30: `varbo status` / export / verify / the dashboard / Study.open on a study a colleague
  // sent loaded every libvarbo_*.so of the folders its meta named: code run by reading a file. Now only folders of
  // this user (or root) that not every user can write; the others are named, and VARBO_PLUGIN_PATH trusts them.
  const fs::path root = test::temp_folder("loader_untrusted_folder");
  fs::create_directories(root / "plugins");
  fs::copy_file(fixture("good"), root / "plugins" / "libvarbo_fixture_good.so");
  std::ofstream(root / "study.yaml") << "task: {type: branin}\nbudget: 6\nseed: 1\nthreads: 1\n"
                                        "plugin_path: [plugins]\n"
                                        "algorithm: {type: bo, initial_points: 3, acquisition: fixture_constant}\n";
  Study::create((root / "st.db").string(), (root / "study.yaml").string());
  CHECK(Study::open((root / "st.db").string()).ask(1).size() == 1);  // this user's folder: loaded

  // Every user can write it (no sticky bit): refused, the warning names the folder and the way to trust it.
  fs::permissions(root / "plugins", fs::perms::others_write, fs::perm_options::add);
  const std::string log = (root / "log.txt").string();
  set_log_file(log);
  CHECK_THROWS_WITH(Study::open((root / "st.db").string()), doctest::Contains("fixture_constant"));
  set_log_file("");
  const std::string said = test::slurp(log);
  CHECK(contains(said, (root / "plugins").string() + ", which every user can write: its plugins are not loaded"));
  CHECK(contains(said, "VARBO_PLUGIN_PATH="));
  fs::permissions(root / "plugins", fs::perms::others_write, fs::perm_options::remove);

  // Another user's folder (when this test runs as root, which may hand it to `nobody`): refused likewise.
  if (::geteuid() == 0) {
    REQUIRE(::chown((root / "plugins").c_str(), 65534, 65534) == 0);
    CHECK_THROWS_WITH(Study::open((root / "st.db").string()), doctest::Contains("fixture_constant"));
    // Trusted on purpose: the same folder given in VARBO_PLUGIN_PATH is loaded.
    ::setenv("VARBO_PLUGIN_PATH", (root / "plugins").c_str(), 1);
    CHECK(Study::open((root / "st.db").string()).ask(1).size() == 1);
    ::unsetenv("VARBO_PLUGIN_PATH");
  }
}

TEST_CASE("a surrogate without gradients: bo and select search the acquisition by its values") {
  // Red team, session 30: the acquisitions read the empty gradients as zeros and said they had one, so a gradient
  // optimizer stopped where it started (and select's local search swallowed an error): the bowl's minimum at the
  // centre was never reached.
  Registry r;
  PluginLoader l(r);
  l.load_default({fixture("good")});
  const std::string folder = test::temp_folder("loader_no_gradient");
  const StudyConfig cfg = parse_study(
      ConfigNode::parse("task: branin\nbudget: 8\nseed: 2\nthreads: 1\nalgorithm: {type: bo, initial_points: 3, "
                        "region: box, surrogate: {type: fixture_bad_model, mode: no_gradient}, acquisition: {type: cb, "
                        "kappa: 0}, acquisition_optimizer: {type: nlopt, algorithm: lbfgs}}\n",
                        "<test>"),
      r);
  Study s = Study::attach(folder + "/s.db", cfg, r);
  for (int i = 0; i < 3; ++i) {
    const auto t = s.ask();
    REQUIRE(t.size() == 1);
    s.tell(t[0].id, 1.0 + i);
  }
  const auto t = s.ask();
  REQUIRE(t.size() == 1);
  CAPTURE(t[0].x.transpose());
  CHECK((t[0].x.array() - 0.5).abs().maxCoeff() < 1e-3);  // the model's minimum, found without gradients
}

TEST_CASE("a third-party surrogate or acquisition with wrong gradient lengths is named before its outputs are used") {
  // Before: release builds check no Eigen sizes, so the built-in acquisitions and optimizers read and wrote past the
  // vectors' ends (garbage suggestions or a crash), naming nobody.
  Registry r;
  PluginLoader l(r);
  l.load_default({fixture("good")});
  auto fourth_ask = [&](const std::string& name, const std::string& algorithm) -> std::string {
    const std::string folder = test::temp_folder("loader_bad_outputs_" + name);
    const StudyConfig cfg = parse_study(
        ConfigNode::parse("task: branin\nbudget: 6\nseed: 2\nthreads: 1\nalgorithm: " + algorithm + "\n", "<test>"), r);
    Study s = Study::attach(folder + "/s.db", cfg, r);
    for (int i = 0; i < 3; ++i) {  // the initial design asks nothing of the model
      const auto t = s.ask();
      REQUIRE(t.size() == 1);
      s.tell(t[0].id, t[0].theta.squaredNorm());
    }
    try {
      const auto t = s.ask();
      CHECK(t.size() == 1);
    } catch (const PluginCodeError& e) {
      CHECK(s.store().pending_trials().empty());  // nothing stored
      return e.what();
    }
    return "(no error)";
  };
  const std::string bo = "{type: bo, initial_points: 3, ";
  CHECK(contains(fourth_ask("short", bo + "surrogate: {type: fixture_bad_model, mode: short_gradient}}"),
                 "surrogate 'fixture/fixture_bad_model' returned a gradient d_mean of length 1, expected 2"));
  // A NaN mean is numerical trouble, not a size bug: survived (the acquisition optimizer's fallback), no error.
  CHECK(fourth_ask("nan", bo + "surrogate: {type: fixture_bad_model, mode: nan_mean}}") == "(no error)");
  CHECK(contains(fourth_ask("long", bo + "acquisition: fixture_long_gradient}"),
                 "acquisition 'fixture/fixture_long_gradient' returned a gradient of length 3 at a point of dimension 2"));
  // The same model with right outputs runs.
  CHECK(fourth_ask("ok", bo + "surrogate: {type: fixture_bad_model, mode: ok}}") == "(no error)");
}
