// `varbo fit` input checks (issue 11, item 7): each bad data file gets exit code 2 and a message naming the
// file, line and column; large fits say what they do.
#include <unistd.h>

#include <cmath>
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
