// Tests of the external task: answers (number, JSON, components), every failure mode as a failed
// trial (exit status, signal, timeout, garbage, NaN), both input modes, no SIGPIPE death, no zombies,
// no hang on background children, and option validation through the registry.
#include <sys/wait.h>

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <fmt/format.h>
#include <functional>
#include <nlohmann/json.hpp>

#include "answer_parser.hpp"
#include "external_task.hpp"
#include "subprocess.hpp"
#include "varbo/errors.hpp"
#include "varbo_test.hpp"

using namespace varbo;
using namespace varbo::tasks;

namespace {
ExternalTaskSettings settings(const std::string& command, Index dim = 2, InputMode mode = InputMode::Json,
                              double timeout = 10) {
  ExternalTaskSettings s;
  s.command = command;
  s.box = Box::unit(dim);
  for (Index i = 0; i < dim; ++i) s.names.push_back(fmt::format("p{}", i));
  s.input = mode;
  s.process.timeout_seconds = timeout;
  return s;
}
Evaluation run(const std::string& command, InputMode mode = InputMode::Json, double timeout = 10) {
  ExternalTask t(settings(command, 2, mode, timeout));
  Vec theta(2);
  theta << 0.25, 0.5;
  Rng rng(1);
  return t.evaluate(theta, rng);
}
bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }
double seconds_of(const std::function<void()>& f) {
  const auto t0 = std::chrono::steady_clock::now();
  f();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace

TEST_CASE("parse_answer") {
  std::string why;
  SUBCASE("plain number on the last non-empty line") {
    auto a = parse_answer("starting\nresult follows\n  -1.5e-3  \n\n", why);
    REQUIRE(a);
    CHECK(a->cost == -1.5e-3);
    CHECK(a->components.empty());
  }
  SUBCASE("JSON object with components, one line or pretty-printed after logs") {
    auto a = parse_answer("log\n{\"cost\": 2.5, \"components\": {\"angle\": 2, \"effort\": 0.5}}\n", why);
    REQUIRE(a);
    CHECK(a->cost == 2.5);
    REQUIRE(a->components.size() == 2);
    CHECK(a->components[0] == std::pair<std::string, double>{"angle", 2.0});
    CHECK(a->components[1] == std::pair<std::string, double>{"effort", 0.5});
    auto b = parse_answer("iter 1 {x}\n{\n  \"cost\": 7,\n  \"components\": {\n    \"a\": 7\n  }\n}\n", why);
    REQUIRE(b);
    CHECK(b->cost == 7);
    CHECK(b->components.size() == 1);
  }
  SUBCASE("rejections say why") {
    CHECK(!parse_answer("", why));
    CHECK(contains(why, "no output"));
    CHECK(!parse_answer("12 apples\n", why));
    CHECK(contains(why, "12 apples"));
    CHECK(!parse_answer("nan\n", why));
    CHECK(contains(why, "not a finite"));
    CHECK(!parse_answer("inf\n", why));
    CHECK(!parse_answer("{\"cost\": \"3\"}\n", why));
    CHECK(contains(why, "not a number"));
    CHECK(!parse_answer("{\"value\": 3}\n", why));
    CHECK(contains(why, "no \"cost\""));
    CHECK(!parse_answer("{\"cost\": 3, \"components\": {\"a\": \"x\"}}\n", why));
    CHECK(contains(why, "component \"a\""));
    CHECK(!parse_answer("{\"cost\": 3,\n", why));
    CHECK(!parse_answer("{broken}\n", why));
    CHECK(contains(why, "neither a number nor a valid JSON"));
    CHECK(!parse_answer("{\"error\": \"solver diverged\"}\n", why));
    CHECK(contains(why, "solver diverged"));
  }
}

TEST_CASE("run_shell: stdin, stdout, stderr, status") {
  ProcessOptions po;
  po.timeout_seconds = 10;
  const ProcessResult r = run_shell("cat; echo err >&2; exit 4", "hello\nworld\n", po);
  CHECK(r.started);
  CHECK(r.exited);
  CHECK(r.exit_status == 4);
  CHECK(r.out == "hello\nworld\n");
  CHECK(r.err == "err\n");
  CHECK(r.status_text() == "exit status 4");
}

TEST_CASE("run_shell: a child that does not read a large stdin causes no SIGPIPE death") {
  ProcessOptions po;
  po.timeout_seconds = 10;
  const std::string big(8u << 20, 'x');  // more than a pipe buffer
  const ProcessResult a = run_shell("exit 0", big, po);
  CHECK(a.exited);
  CHECK(a.exit_status == 0);
  const ProcessResult b = run_shell("head -c 10 >/dev/null; echo 1", big, po);
  CHECK(b.exited);
  CHECK(b.out == "1\n");
}

TEST_CASE("run_shell: output beyond the cap keeps the tail") {
  ProcessOptions po;
  po.timeout_seconds = 20;
  po.max_stdout = 1u << 16;
  const ProcessResult r = run_shell("head -c 3000000 /dev/zero | tr '\\0' a; echo; echo 7", "", po);
  CHECK(r.exited);
  CHECK(r.out.size() <= po.max_stdout);
  std::string why;
  auto a = parse_answer(r.out, why);
  REQUIRE(a);
  CHECK(a->cost == 7);
}

TEST_CASE("external task: answers") {
  SUBCASE("a shell command that echoes a cost") {
    const Evaluation e = run("echo 3.25");
    CHECK(e.ok);
    CHECK(e.cost == 3.25);
    CHECK(e.components.empty());
  }
  SUBCASE("JSON answer with components") {
    const Evaluation e = run("echo '{\"cost\": 2.5, \"components\": {\"a\": 2, \"b\": 0.5}}'");
    REQUIRE(e.ok);
    CHECK(e.cost == 2.5);
    REQUIRE(e.components.size() == 2);
    CHECK(e.components[0].first == "a");
    CHECK(e.components[1].second == 0.5);
  }
  SUBCASE("json input mode: θ, names and trial arrive on stdin") {
    // The shell checks the document it received and answers 1.5 only if θ is there verbatim.
    const Evaluation e = run("read -r line; case \"$line\" in *'\"theta\":[0.25,0.5]'*) echo 1.5;; *) echo \"got $line\";; esac");
    CHECK(e.ok);
    CHECK(e.cost == 1.5);
    ExternalTask t(settings("true"));
    Vec theta(2);
    theta << 0.1, 1.0 / 3.0;
    const auto j = nlohmann::json::parse(t.json_input(theta, 7));
    CHECK(j["trial"] == 7);
    CHECK(j["names"] == nlohmann::json({"p0", "p1"}));
    CHECK(j["theta"][1].get<double>() == 1.0 / 3.0);  // exact round trip
  }
  SUBCASE("trial counter increases per evaluation") {
    ExternalTask t(settings("read -r line; case \"$line\" in *'\"trial\":1'*) echo 1;; *) echo 0;; esac"));
    Rng rng(1);
    CHECK(t.evaluate(Vec::Zero(2), rng).cost == 0);
    CHECK(t.evaluate(Vec::Zero(2), rng).cost == 1);
  }
  SUBCASE("args mode appends θ as arguments") {
    // "f 0.25 0.5" runs the function: it answers its second argument and the argument count.
    const Evaluation e = run("f() { echo \"{\\\"cost\\\": $2, \\\"components\\\": {\\\"n\\\": $#}}\"; }; f", InputMode::Args);
    REQUIRE(e.ok);
    CHECK(e.cost == 0.5);
    REQUIRE(e.components.size() == 1);
    CHECK(e.components[0].second == 2);
    ExternalTask t(settings("sim", 2, InputMode::Args));
    Vec theta(2);
    theta << -1e-300, 0.1;
    // 17 significant digits: every double round-trips through the text.
    CHECK(t.command_with_args(theta) == "sim -1e-300 0.10000000000000001");
    CHECK(std::strtod("0.10000000000000001", nullptr) == 0.1);
  }
  SUBCASE("working directory") {
    ExternalTaskSettings s = settings("test \"$(pwd)\" = / && echo 1 || echo 0");
    s.process.working_directory.assign(1, '/');  // (assign: dodges a GCC 12 -Wrestrict false positive)
    ExternalTask t(s);
    Rng rng(1);
    CHECK(t.evaluate(Vec::Zero(2), rng).cost == 1);
  }
}

TEST_CASE("external task: failures are failed trials with a message") {
  SUBCASE("non-zero exit: status, last stdout line and stderr tail") {
    const Evaluation e = run("echo partial 1.0; echo 'solver: singular matrix' >&2; exit 3");
    CHECK(!e.ok);
    CHECK(contains(e.error, "exit status 3"));
    CHECK(contains(e.error, "partial 1.0"));
    CHECK(contains(e.error, "singular matrix"));
  }
  SUBCASE("command not found") {
    const Evaluation e = run("/nonexistent/varbo-simulator");
    CHECK(!e.ok);
    CHECK(contains(e.error, "exit status 127"));
  }
  SUBCASE("killed by a signal") {
    const Evaluation e = run("kill -9 $$");
    CHECK(!e.ok);
    CHECK(contains(e.error, "signal 9"));
  }
  SUBCASE("garbage, NaN and empty answers") {
    for (const char* cmd : {"echo hello", "echo nan", "true", "echo '{\"cost\": null}'", "echo '{\"error\": \"diverged\"}'"}) {
      CAPTURE(cmd);
      const Evaluation e = run(cmd);
      CHECK(!e.ok);
      CHECK(contains(e.error, "exit status 0"));
    }
    CHECK(contains(run("echo hello").error, "'hello'"));
    CHECK(contains(run("echo '{\"error\": \"diverged\"}'").error, "diverged"));
  }
  SUBCASE("timeout: a sleeping child finishes quickly and is a failed trial") {
    Evaluation e;
    const double t = seconds_of([&] { e = run("echo 1; sleep 30", InputMode::Json, 0.5); });
    CHECK(!e.ok);
    CHECK(contains(e.error, "timed out"));
    CHECK(t >= 0.45);
    CHECK(t < 2.0);
  }
  SUBCASE("timeout: a child ignoring SIGTERM is killed anyway") {
    Evaluation e;
    const double t = seconds_of([&] { e = run("trap '' TERM; sleep 30; sleep 30", InputMode::Json, 0.3); });
    CHECK(!e.ok);
    CHECK(t < 2.0);
  }
  SUBCASE("a child that closes stdout and keeps running is still bounded by the timeout") {
    Evaluation e;
    const double t = seconds_of([&] { e = run("exec >&- 2>&-; sleep 30", InputMode::Json, 0.3); });
    CHECK(!e.ok);
    CHECK(t < 2.0);
  }
}

TEST_CASE("external task: a background job left by the command does not block the trial") {
  Evaluation e;
  const double t = seconds_of([&] { e = run("sleep 30 & echo 4"); });
  CHECK(e.ok);
  CHECK(e.cost == 4);
  CHECK(t < 2.0);
}

TEST_CASE("external task: no zombies are left") {
  for (int k = 0; k < 5; ++k) {
    run("echo 1");
    run("exit 2");
    run("sleep 5", InputMode::Json, 0.1);
  }
  errno = 0;
  CHECK(::waitpid(-1, nullptr, WNOHANG) == -1);  // no child at all, dead or alive
  CHECK(errno == ECHILD);
}

TEST_CASE("external task through the registry: options") {
  Registry& reg = test::registry();
  BuildContext ctx;
  SUBCASE("dimension from lower/upper, names, input mode") {
    auto t = reg.create<Task>("{type: external, command: 'echo 1', lower: [0, -1], upper: [1, 1], names: [a, b]}", ctx);
    const Domain d = t->domain();
    CHECK(d.box.dim() == 2);
    CHECK(d.box.lower[1] == -1);
    CHECK(d.names == std::vector<std::string>{"a", "b"});
    Rng rng(1);
    CHECK(t->evaluate(Vec::Zero(2), rng).cost == 1);
  }
  SUBCASE("dim with bounds, default names") {
    auto t = reg.create<Task>("{type: external, command: 'echo 1', dim: 3, bounds: [-2, 2], input: args}", ctx);
    CHECK(t->domain().box.upper.isApproxToConstant(2));
    CHECK(t->domain().names[2] == "x3");
  }
  SUBCASE("inconsistent or missing settings are ConfigErrors") {
    for (const char* y : {"{type: external, dim: 2}",
                          "{type: external, command: 'echo 1'}",
                          "{type: external, command: 'echo 1', dim: 2, names: [a]}",
                          "{type: external, command: 'echo 1', names: [a, a]}",
                          "{type: external, command: 'echo 1', lower: [0, 0]}",
                          "{type: external, command: 'echo 1', lower: [0, 0], upper: [1]}",
                          "{type: external, command: 'echo 1', lower: [0], upper: [0]}",
                          "{type: external, command: 'echo 1', lower: [0], upper: [1], bounds: [0, 1]}",
                          "{type: external, command: 'echo 1', dim: 2, bounds: [1, 0]}",
                          "{type: external, command: 'echo 1', dim: 2, timeout: 0}",
                          "{type: external, command: 'echo 1', dim: 2, input: stdin}",
                          "{type: external, command: ' ', dim: 2}"}) {
      CAPTURE(y);
      CHECK_THROWS_AS(reg.create<Task>(y, ctx), ConfigError);
    }
  }
}
