// Plugin loading: good, broken, foreign and mismatched libraries each give a clear, file-naming error.
#include <filesystem>
#include <fstream>

#include "varbo/errors.hpp"
#include "varbo/loader.hpp"
#include "varbo/plugin.hpp"
#include "varbo_test.hpp"

using namespace varbo;

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

TEST_CASE("a truncated library is refused with the dynamic loader's reason") {
  const std::string trunc = std::filesystem::temp_directory_path() / "libvarbo_truncated_test.so";
  {
    std::ifstream in(fixture("good"), std::ios::binary);
    std::ofstream out(trunc, std::ios::binary | std::ios::trunc);
    std::vector<char> buf(200);
    in.read(buf.data(), 200);
    out.write(buf.data(), 200);
  }
  const std::string m = error_loading<PluginLoadError>(trunc);
  CHECK(contains(m, trunc + ": cannot load:"));
  std::filesystem::remove(trunc);
}

TEST_CASE("a plugin whose registration throws reports the reason") {
  const std::string m = error_loading<PluginLoadError>(fixture("throws"));
  CHECK(contains(m, "failed to register: fixture refuses to register"));
}

TEST_CASE("a missing file is named") {
  CHECK(error_loading<PluginLoadError>("/nonexistent/libvarbo_x.so") ==
        "/nonexistent/libvarbo_x.so: plugin library not found");
}

TEST_CASE("scanning a folder loads the good library once and records every bad one") {
  Registry r;
  PluginLoader l(r);
  l.load_directory(VARBO_FIXTURE_DIR);
  // Sorted: abi, build, foreign, good, text, throws. good loads; "throws" carries the same plugin name
  // as good, so it is shadowed (first wins) and never runs; the other four are skipped with reasons.
  CHECK(l.loaded().size() == 1);
  CHECK(l.skipped().size() == 4);
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
