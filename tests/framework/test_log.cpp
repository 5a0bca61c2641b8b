// Logging: what reaches a run's log file, and InfoAsDebug (a replayed study's info lines are not said again).
#include <thread>

#include "study_helpers.hpp"
#include "varbo/log.hpp"
#include "varbo_test.hpp"

using namespace varbo;

TEST_CASE("InfoAsDebug demotes this thread's info lines only, warnings pass, and it nests") {
  const std::string dir = test::temp_folder("log_info_as_debug");
  const std::string file = dir + "/log.txt";
  const LogLevel before = log_level();
  set_log_level(LogLevel::Quiet);  // keep the terminal clean; the file takes every level >= Info
  set_log_file(file);
  log_info("said before");
  {
    const InfoAsDebug outer;
    log_info("replayed one");
    {
      const InfoAsDebug inner;
      log_info("replayed two");
    }
    log_info("replayed three");  // still inside the outer one
    log_warn("a warning while replaying");
    std::thread other([] { log_info("another thread's line"); });  // the scope is this thread's
    other.join();
  }
  log_info("said after");
  set_log_file("");
  set_log_level(before);

  const std::string text = test::slurp(file);
  CHECK(text.find("said before") != std::string::npos);
  CHECK(text.find("said after") != std::string::npos);
  CHECK(text.find("a warning while replaying") != std::string::npos);
  CHECK(text.find("another thread's line") != std::string::npos);
  CHECK(text.find("replayed one") == std::string::npos);
  CHECK(text.find("replayed two") == std::string::npos);
  CHECK(text.find("replayed three") == std::string::npos);
}
