// `varbo fit` input checks (issue 11, item 7): each bad data file gets exit code 2 and a message naming the
// file, line and column; large fits say what they do.
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <fmt/format.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "process.hpp"
#include "study_helpers.hpp"
#include "varbo_test.hpp"

using namespace varbo;
using test::slurp;
namespace fs = std::filesystem;

namespace {

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

struct Fit {
  int exit_code;
  std::string output;
};

Fit fit(const std::string& dir, const std::string& surrogate, const std::string& data, std::vector<std::string> extra = {}) {
  const std::string s = dir + "/s.yaml", d = dir + "/d.csv", log = dir + "/out.txt";
  std::ofstream(s, std::ios::trunc) << surrogate;
  std::ofstream(d, std::ios::trunc) << data;
  fs::remove(log);
  std::vector<std::string> args = {VARBO_EXE, "fit", "--surrogate", s, "--data", d, "--threads", "1"};
  args.insert(args.end(), extra.begin(), extra.end());
  return {test::run(args, log).exit_code, slurp(log)};
}

const char* kGp = "type: gp\nkernel: se_ard\nhyperparameters: {\"lengthscale[0]\": 0.3, signal_std: 1.0, noise_std: 0.1}\n";
const char* kData = "x,y\n0.1,1\n0.5,2\n0.9,1.5\n";

}  // namespace

TEST_CASE("varbo fit: malformed data files are refused with file:line and column") {
  const std::string dir = test::temp_folder("fit_inputs_" + std::to_string(getpid()));
  const std::string d = dir + "/d.csv";
  struct Case {
    std::string data, message;
    std::vector<std::string> extra;
  };
  const std::vector<Case> cases = {
      {"x,y,y\n0.1,1,2\n0.5,2,3\n", d + ":1: column name 'y' appears twice (columns 2 and 3)", {}},
      {"x1,y\n0.1,1\n0.5,2\n", "--columns: 'y' is the target", {"--columns", "x1,y"}},
      {"x,y\n", d + ": no data rows after the header", {}},
      {"x,y\n0.1,1\n0.5,nan\n", d + ":3: column 'y': nan is not a finite number", {}},
      {"x,y\n0.1,1\ninf,2\n", d + ":3: column 'x': inf is not a finite number", {}},
      {"x,y\n0.1,0x10\n", d + ":2: column 'y': expected a decimal number, got '0x10'", {}},
      {"x,y\n0.1,1e300\n0.5,2e300\n0.9,-1e300\n", d + ":2: column 'y': 1e+300 is too large in magnitude", {}},
      {"x,,y\n0.1,1,2\n", d + ":1: column 2 of the header has no name", {}},
      // A quote opened on line 2 and never closed: named where the value began (audit, session 48).
      {"x,y\n\"0.1,1\n0.5,2\n", d + ":2: unterminated quote (the value opened here never closes)", {}},
  };
  for (const auto& c : cases) {
    INFO(c.data);
    const Fit r = fit(dir, kGp, c.data, c.extra);
    CHECK(r.exit_code == 2);
    CHECK_MESSAGE(contains(r.output, c.message), r.output);
  }
  // vhgp with no rows and points to predict at: a clear error, not "internal error".
  std::ofstream(dir + "/p.csv") << "x\n0.5\n";
  const Fit v = fit(dir, "type: vhgp\n", "x,y\n", {"--predict", dir + "/p.csv"});
  CHECK(v.exit_code == 2);
  CHECK(contains(v.output, "no data rows"));
  // Points to predict at are checked like the data.
  std::ofstream(dir + "/q.csv") << "x\n0.5\nnan\n";
  const Fit q = fit(dir, kGp, kData, {"--no-optimize", "--predict", dir + "/q.csv"});
  CHECK(q.exit_code == 2);
  CHECK(contains(q.output, dir + "/q.csv:3: column 'x': nan is not a finite number"));
  // Audit, session 48: pandas' default DataFrame.to_csv (",x,y": its index under an empty first name) was refused;
  // it reads as pandas reads it back ("Unnamed: 0") and is skipped as an index. A quoted note holding a line break
  // (RFC 4180) was refused as an unterminated quote; its row keeps the line where it began.
  const Fit pandas = fit(dir, kGp, ",x,y\n0,0.1,1\n1,0.5,2\n2,0.9,1.5\n", {"--no-optimize"});
  CHECK(pandas.exit_code == 0);
  CHECK(contains(pandas.output, "column 'Unnamed: 0' is a pandas index"));
  CHECK(contains(pandas.output, "\"n\": 3"));
  const Fit notes = fit(dir, kGp, "x,note,y\n0.1,\"fell, then\nrecovered\",1\n0.5,\"ok \"\"good\"\"\",2\n0.9,ok,nan\n",
                        {"--no-optimize", "--columns", "x"});
  CHECK(notes.exit_code == 2);
  CHECK_MESSAGE(contains(notes.output, d + ":5: column 'y': nan is not a finite number"), notes.output);
  const Fit notes_ok = fit(dir, kGp, "x,note,y\n0.1,\"fell, then\nrecovered\",1\n0.5,\"ok \"\"good\"\"\",2\n0.9,ok,1.5\n",
                           {"--no-optimize", "--columns", "x"});
  CHECK(notes_ok.exit_code == 0);
  CHECK(contains(notes_ok.output, "\"n\": 3"));
  // The same data, well formed, fits.
  const Fit ok = fit(dir, kGp, kData, {"--no-optimize", "--predict", dir + "/p.csv"});
  CHECK(ok.exit_code == 0);
  CHECK(contains(ok.output, "\"n\": 3"));
  fs::remove_all(dir);
}

TEST_CASE("varbo fit: past 500 points and without `restarts:`, one restart, said on stderr") {
  const std::string dir = test::temp_folder("fit_large_" + std::to_string(getpid()));
  std::string data = "x,y\n";
  for (int i = 0; i < 501; ++i) {
    const double x = i / 500.0;
    data += std::to_string(x) + "," + std::to_string(std::sin(6 * x)) + "\n";
  }
  // One L-BFGS iteration keeps the test fast; the rule does not depend on the optimizer.
  const std::string cheap = "type: gp\nkernel: se_ard\nfit_optimizer: {type: ceres_lbfgs, max_iterations: 1}\n";
  const Fit a = fit(dir, cheap, data);
  CHECK(contains(a.output, "501 points (> 500) and no `restarts:` given: 1 restart instead of 4"));
  const Fit b = fit(dir, cheap + std::string("restarts: 2\n"), data);
  CHECK_FALSE(contains(b.output, "restart instead"));
  CHECK(contains(b.output, "\"n\": 501"));
  fs::remove_all(dir);
}

TEST_CASE("varbo fit: θ columns far from unit scale are named with the advice to rescale them") {
  // Red team, session 25: x in [0, 1000] (sin(6 x / 1000)) was fitted as noise, ok: true, no word; the lengthscale
  // bounds and priors are for unit-cube coordinates.
  const std::string dir = test::temp_folder("fit_scale_" + std::to_string(getpid()));
  std::string wide = "x,z,y\n", unit = "x,z,y\n";
  for (int i = 0; i < 15; ++i) {
    const double x = i / 14.0;
    wide += fmt::format("{},{},{}\n", 1000 * x, 0.5 * x, std::sin(6 * x));
    unit += fmt::format("{},{},{}\n", x, 0.5 * x, std::sin(6 * x));
  }
  const Fit a = fit(dir, "type: gp\n", wide);
  CHECK(a.exit_code == 0);
  CHECK(contains(a.output, "column 1 spans 1e+03 (0 … 1000)"));
  CHECK_FALSE(contains(a.output, "column 2 spans"));
  CHECK(contains(a.output, "rescale each θ column to [0, 1]"));
  const Fit b = fit(dir, "type: gp\n", unit);
  CHECK(b.exit_code == 0);
  CHECK_FALSE(contains(b.output, "spans"));
  // Given hyperparameters (no fit): the user chose the lengthscales, nothing to say.
  CHECK_FALSE(contains(fit(dir, kGp, "x,y\n0,1\n500,2\n1000,1.5\n", {"--no-optimize"}).output, "spans"));
  fs::remove_all(dir);
}

TEST_CASE("varbo fit --no-optimize: a vhgp needs every hyperparameter and one log Lambda per point") {
  // Issue 12, item 8: conditioning without a fit used to pad short lists (lengthscales 0.3, log Lambda log 1/2),
  // drop extra log Lambda values and default a missing mu0, silently.
  const std::string dir = test::temp_folder("fit_vhgp_given_" + std::to_string(getpid()));
  const std::string data = "x1,x2,y\n0.1,0.2,1\n0.5,0.5,2\n0.9,0.7,1.5\n";
  auto yaml = [](const std::string& lengthscales_f, const std::string& mu0, const std::string& log_lambda) {
    return "type: vhgp\nhyperparameters: {lengthscale_f: " + lengthscales_f +
           ", signal_std_f: 1.0, lengthscale_g: 0.4, signal_std_g: 0.8" + mu0 + "}\n" + log_lambda;
  };
  const std::string full_f = "[0.3, 0.5]", mu0 = ", mu0: -3", lambda3 = "log_lambda: [-0.7, -0.6, -0.8]\n";
  struct Case {
    std::string yaml, message;
  };
  const std::vector<Case> cases = {
      {yaml("[0.3]", mu0, lambda3), "key 'hyperparameters.lengthscale_f': expected 2 lengthscales (one per dimension), got 1"},
      {yaml("[0.3, 0.5, 0.7]", mu0, lambda3), "expected 2 lengthscales (one per dimension), got 3"},
      {yaml(full_f, "", lambda3), "every hyperparameter must be given; missing: mu0"},
      {yaml(full_f, mu0, "log_lambda: [-0.7, -0.6]\n"), "key 'log_lambda': the vhgp is conditioned without a fit"},
      {yaml(full_f, mu0, "log_lambda: [-0.7, -0.6]\n"), "expected 3 values (one per data point), got 2"},
      {yaml(full_f, mu0, "log_lambda: [-0.7, -0.6, -0.8, -0.9]\n"), "expected 3 values (one per data point), got 4"},
      {yaml(full_f, mu0, ""), "log_lambda must be given: expected 3 values"},
      {"type: vhgp\n", "missing: lengthscale_f[0], lengthscale_f[1], signal_std_f, lengthscale_g[0]"},
  };
  for (const auto& c : cases) {
    INFO(c.yaml);
    const Fit r = fit(dir, c.yaml, data, {"--no-optimize"});
    CHECK(r.exit_code == 2);
    CHECK_MESSAGE(contains(r.output, c.message), r.output);
    CHECK_MESSAGE(contains(r.output, dir + "/s.yaml:"), r.output);  // the file is named
  }
  // Complete: conditions, and reports the standardization y_s = (y − mean)/scale it used (mean 1.5, sd 0.5).
  const Fit ok = fit(dir, yaml(full_f, mu0, lambda3), data, {"--no-optimize"});
  CHECK(ok.exit_code == 0);
  const std::size_t at = ok.output.find("\"standardization\": [");
  REQUIRE_MESSAGE(at != std::string::npos, ok.output);
  char* end = nullptr;
  const char* p = ok.output.c_str() + at + std::string("\"standardization\": [").size();
  const double mean = std::strtod(p, &end);
  const double scale = std::strtod(end + 1, nullptr);  // skip the comma
  CHECK(mean == doctest::Approx(1.5).epsilon(1e-12));
  CHECK(scale == doctest::Approx(0.5).epsilon(1e-12));
  // A fit uses the given values only as a start: a short log Lambda list is padded there (documented).
  CHECK(fit(dir, yaml(full_f, mu0, "log_lambda: [-0.7]\n"), data).exit_code == 0);
  fs::remove_all(dir);
}
