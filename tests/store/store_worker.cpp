// A worker process for the concurrency test: N cycles of open / ask / tell on one study file, each cycle a
// fresh Study like a `varbo suggest` + `varbo observe` pair. Exit code 0 when every cycle got a trial.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "varbo/study_api.hpp"

int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: store_worker STUDY.db CYCLES NAME\n");
    return 2;
  }
  const std::string file = argv[1];
  const int cycles = std::atoi(argv[2]);
  const std::string name = argv[3];
  try {
    for (int i = 0; i < cycles; ++i) {
      std::int64_t id = -1;
      varbo::Vec theta;
      {
        varbo::Study s = varbo::Study::open(file);
        s.set_worker(name);
        const auto t = s.ask(1);
        if (t.empty()) {
          std::fprintf(stderr, "%s: cycle %d: nothing suggested\n", name.c_str(), i);
          return 1;
        }
        id = t[0].id;
        theta = t[0].theta;
      }
      // The "evaluation" happens outside any transaction; the result names its worker and cycle.
      varbo::Study s = varbo::Study::open(file);
      s.tell(id, theta.squaredNorm(), {{"cycle", static_cast<double>(i)}});
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: error: %s\n", name.c_str(), e.what());
    return 1;
  }
  return 0;
}
