// varbo: risk-aware and cautious Bayesian optimization from YAML configurations.
#include <fcntl.h>
#include <malloc.h>
#include <unistd.h>

#include <cctype>
#include <csignal>
#include <cerrno>
#include <cstdio>
#include <filesystem>
#include <cstring>
#include <string>
#include <map>

#include "cli_parse.hpp"
#include "commands.hpp"
#include "varbo/text.hpp"
#include "varbo/errors.hpp"
#include "varbo/interrupt.hpp"
#include "varbo/log.hpp"
#include "varbo/plugin.hpp"
#include "varbo/version.hpp"

namespace {

// CLI11 reads `-nan` or `-inf` as a cluster of short options, so `varbo observe S 3 -nan` said only "cost is
// required". Name the token and what a cost must be (a negative finite number such as -1.5 is read as a cost).
void hint_non_finite_numbers(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    std::string t = argv[i];
    for (char& c : t) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (t == "-nan" || t == "-inf" || t == "-infinity")
      std::fprintf(stderr,
                   "varbo: '%s' is read as an option, not as a number: a cost must be a finite number (a trial "
                   "that gave no cost is recorded with `varbo fail STORE ID`)\n",
                   argv[i]);
    // "-.5" (CLI11 takes "-0.5" as a number, not "-.5"): said with the way out, not only "cost is required".
    else if (t.size() >= 3 && t[0] == '-' && t[1] == '.' && std::isdigit(static_cast<unsigned char>(t[2])))
      std::fprintf(stderr,
                   "varbo: '%s' is read as an option, not as a number: write -0%s, or put -- before it "
                   "(varbo observe STORE ID -- %s)\n",
                   argv[i], argv[i] + 1, argv[i]);
  }
}

}  // namespace

int main(int argc, char** argv) {
  // Standard descriptors closed by the caller (`varbo run ... 1>&-`, a daemon's launcher) are opened on /dev/null
  // before anything opens a file: a complete, recorded run ended with exit 2 "standard output: write failed", and
  // with all three closed the run lock became fd 2, inherited by the trial supervisor and written to by every
  // message (red team, session 37). open() returns the lowest free descriptor, the one closed.
  for (int fd = 0; fd <= 2; ++fd)
    if (::fcntl(fd, F_GETFD) == -1 && errno == EBADF) {
      const int got = ::open("/dev/null", O_RDWR);
      if (got >= 0 && got != fd) ::close(got);  // cannot happen (0 … fd − 1 are open by now); never kept if it did
    }
  // Keep freed blocks in the heap. glibc gives a big block (a GP fit's N × N matrices: 1.3 MB at N = 400) back
  // to the kernel when it is freed and maps fresh zeroed pages for the next one until its dynamic threshold has
  // adapted, which a short process never does: `varbo suggest` took 33,000 page faults and ~30 % more CPU for
  // its one fit than with the blocks kept (docs/studies.md, "Cost of varbo suggest"). Blocks over 256 MB are
  // still mapped; the heap is trimmed only past 1 GB free.
  mallopt(M_MMAP_THRESHOLD, 256 << 20);
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
  // A closed output pipe is an error to handle, not a death: `varbo run CFG 2>&1 | tee log` over ssh gets SIGHUP
  // and then writes to a pipe whose reader is gone; the default SIGPIPE killed varbo half-way through stopping
  // (no "continue it with" line in log.txt, the run lock left behind). Commands a task runs get the default back
  // (process_tree.cpp resets it before exec).
  std::signal(SIGPIPE, SIG_IGN);
  // Past `ulimit -f` a write fails with EFBIG, handled as any failed write (the store's error, the evaluated
  // result printed with the command that records it); the default SIGXFSZ killed varbo silently (exit 153) and
  // lost that result (red team, session 25).
  std::signal(SIGXFSZ, SIG_IGN);
  CLI::App app{"varbo " VARBO_VERSION_STRING
               ": sample-efficient, risk-aware and cautious Bayesian optimization\n"
               "Compose an algorithm in YAML, run it, inspect models. See README.md."};
  app.require_subcommand(1);
  // A bug report and a third-party plugin build need both: the release, and the fingerprint a plugin must match
  // to be loaded (plugin.hpp, VARBO_BUILD_FINGERPRINT).
  app.set_version_flag("-V,--version", [] {
    return std::string("varbo " VARBO_VERSION_STRING "\nplugin build fingerprint: ") + varbo::host_fingerprint();
  });
  bool verbose = false, quiet = false;
  CLI::Option* verbose_flag = app.add_flag("-v,--verbose", verbose, "debug logging");
  // Both given, -q won in silence (audit, session 44): they contradict each other.
  app.add_flag("-q,--quiet", quiet, "warnings and errors only (before the subcommand: `varbo -q run ...`; the "
                                    "per-trial progress lines are `run --no-progress`)")
      ->excludes(verbose_flag);
  std::map<CLI::App*, varbo::cli::Runner> runners;
  auto reg = [&](varbo::cli::Runner (*add)(CLI::App&)) {
    const std::size_t before = app.get_subcommands({}).size();
    varbo::cli::Runner r = add(app);
    auto subs = app.get_subcommands({});
    if (subs.size() > before) runners[subs.back()] = std::move(r);
  };
  reg(&varbo::cli::add_run);
  reg(&varbo::cli::add_plugins);
  reg(&varbo::cli::add_fit);
  reg(&varbo::cli::add_rescore);
  reg(&varbo::cli::add_study);
  reg(&varbo::cli::add_suggest);
  reg(&varbo::cli::add_observe);
  reg(&varbo::cli::add_fail);
  reg(&varbo::cli::add_abandon);
  reg(&varbo::cli::add_retract);
  reg(&varbo::cli::add_status);
  reg(&varbo::cli::add_worker);
  reg(&varbo::cli::add_export);
  reg(&varbo::cli::add_select);
  reg(&varbo::cli::add_plot);
  reg(&varbo::cli::add_dashboard);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help/--version exit 0; any other command-line mistake is a user error: exit 2 like every other one.
    if (app.exit(e) == 0) return 0;
    hint_non_finite_numbers(argc, argv);
    return 2;
  }
  if (verbose) varbo::set_log_level(varbo::LogLevel::Debug);
  if (quiet) varbo::set_log_level(varbo::LogLevel::Warn);
  try {
    varbo::cli::refuse_empty_values(app);
    for (auto& [sub, run] : runners)
      if (sub->parsed()) {
        const int rc = run();
        // printf ignores a full disk or a closed file: `varbo export --csv S > /dev/full` exited 0 with the
        // data lost. A failed write of standard output is the command's failure.
        if (std::fflush(stdout) != 0 || std::ferror(stdout)) {
          // `varbo export S | head -1`: the reader left on purpose; end as a process killed by SIGPIPE would.
          const int err = errno;
          // observe, fail, abandon and study create print only a confirmation of a change already committed:
          // exit 2 ("nothing written") after `observe S 0 1.25 > /dev/full` made a script retry, and the retry
          // was refused as "already complete" (red team, session 29).
          // `run` too: its results are in its folder; stdout only followed them (`varbo run CFG | head -2`
          // exited 141 after a complete run; audit, session 47).
          const bool recorded = rc == 0 && (sub->get_name() == "observe" || sub->get_name() == "fail" ||
                                            sub->get_name() == "run" ||
                                            sub->get_name() == "abandon" ||
                                            (sub->get_name() == "study" && sub->get_subcommand("create")->parsed()));
          if (recorded) {
            std::fprintf(stderr, "varbo: warning: standard output: write failed (%s); %s\n", std::strerror(err),
                         sub->get_name() == "run" ? "the run is complete and recorded in its folder"
                                                  : "the change was recorded");
            return 0;
          }
          if (err == EPIPE) return rc != 0 ? rc : 128 + SIGPIPE;
          std::fprintf(stderr, "varbo: error: standard output: write failed (%s)\n", std::strerror(err));
          return rc != 0 ? rc : 2;
        }
        return rc;
      }
  } catch (const varbo::Interrupted& e) {
    std::fprintf(stderr, "varbo: %s\n", varbo::terminal_text(varbo::hide_url_passwords(e.what())).c_str());
    return 128 + e.signal();  // as a shell reports a process killed by that signal
  } catch (const varbo::Error& e) {
    std::fprintf(stderr, "varbo: error: %s\n", varbo::terminal_text(varbo::hide_url_passwords(e.what())).c_str());
    return 2;
  } catch (const std::filesystem::filesystem_error& e) {
    // A path the system refuses (a symlink loop, a name too long, a folder that cannot be searched) is the user's
    // to fix, not a bug: it ended in "internal error", exit 3 (fuzzing, session 27).
    std::fprintf(stderr, "varbo: error: %s: %s\n", varbo::terminal_text(e.path1().string()).c_str(),
                 e.code().message().c_str());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "varbo: internal error: %s\n", varbo::terminal_text(varbo::hide_url_passwords(e.what())).c_str());
    return 3;
  } catch (...) {  // not a std::exception (`throw 7` in plugin code): std::terminate ended the process before
    std::fprintf(stderr, "varbo: internal error: an exception that is not a std::exception\n");
    return 3;
  }
  return 0;
}
