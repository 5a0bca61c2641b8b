// The bad-input corpus: every case in cases/*.cases runs the built `varbo` on hostile input and checks that it
// answers like a tool a user can trust overnight: the expected exit code (2 for user errors), a message naming
// the file:line:col, file or trial, no crash (signal, exit 3 "internal error", sanitizer report), no hang
// (timeout), and no partial state (a rejected command creates nothing in its folder). Format: cases/README.md.
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <doctest/doctest.h>

namespace fs = std::filesystem;
extern char** environ;

namespace {

struct InlineFile {
  std::string path, text;
  bool executable = false;
};

struct Case {
  std::string name, source;  ///< name and "file:line" of its `===` line
  std::string pending;
  std::vector<std::pair<std::string, std::string>> steps;  ///< ("sh" | "setup", text), in file order
  std::vector<std::string> env, expect, expect_once, reject, absent, exists, allow_new, utf8;
  std::vector<std::pair<std::string, std::string>> file_contains;
  std::vector<std::pair<std::string, long>> max_size;
  std::vector<InlineFile> files;
  std::string cmd;
  int exit_code = 2;
  double timeout = 30;
};

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r");
  if (b == std::string::npos) return "";
  return s.substr(b, s.find_last_not_of(" \t\r") - b + 1);
}

std::string substitute(std::string s, const std::map<std::string, std::string>& vars) {
  for (const auto& [k, v] : vars)
    for (std::size_t pos = 0; (pos = s.find(k, pos)) != std::string::npos; pos += v.size()) s.replace(pos, k.size(), v);
  return s;
}

/// Splits a command line like a shell without expansions: blanks separate, '...' and "..." quote, \ escapes.
std::vector<std::string> split_args(const std::string& line) {
  std::vector<std::string> out;
  std::string cur;
  bool have = false;
  char quote = 0;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quote) {
      if (c == quote) quote = 0;
      else if (c == '\\' && quote == '"' && i + 1 < line.size()) cur += line[++i];
      else cur += c;
    } else if (c == '\'' || c == '"') {
      quote = c;
      have = true;
    } else if (c == '\\' && i + 1 < line.size()) {
      cur += line[++i];
      have = true;
    } else if (c == ' ' || c == '\t') {
      if (have) out.push_back(cur);
      cur.clear();
      have = false;
    } else {
      cur += c;
      have = true;
    }
  }
  if (have) out.push_back(cur);
  return out;
}

std::vector<Case> parse_cases(const fs::path& file) {
  std::ifstream in(file);
  std::vector<Case> out;
  std::string line;
  int lineno = 0;
  auto fail = [&](const std::string& why) {
    FAIL_CHECK(file.string() << ":" << lineno << ": " << why);
  };
  while (std::getline(in, line)) {
    ++lineno;
    const std::string t = trim(line);
    if (t.empty() || t[0] == '#') continue;
    if (t.rfind("===", 0) == 0) {
      out.emplace_back();
      out.back().name = trim(t.substr(3));
      out.back().source = file.filename().string() + ":" + std::to_string(lineno);
      continue;
    }
    if (out.empty()) {
      fail("directive before the first '=== name'");
      continue;
    }
    Case& c = out.back();
    if (t.rfind("<<<", 0) == 0) {
      InlineFile f;
      std::vector<std::string> words = split_args(t.substr(3));
      if (words.empty()) fail("'<<<' needs a file name");
      f.path = words.empty() ? "" : words[0];
      f.executable = std::find(words.begin(), words.end(), "exec") != words.end();
      bool closed = false;
      while (std::getline(in, line)) {
        ++lineno;
        if (trim(line) == ">>>") {
          closed = true;
          break;
        }
        f.text += line + "\n";
      }
      if (!closed) fail("'<<< " + f.path + "' is not closed by '>>>'");
      c.files.push_back(f);
      continue;
    }
    const auto colon = t.find(':');
    if (colon == std::string::npos) {
      fail("expected 'key: value', got '" + t + "'");
      continue;
    }
    const std::string key = t.substr(0, colon), value = trim(t.substr(colon + 1));
    if (key == "cmd") c.cmd = value;
    else if (key == "exit") c.exit_code = std::stoi(value);
    else if (key == "timeout") c.timeout = std::stod(value);
    else if (key == "pending") c.pending = value.empty() ? "pending" : value;
    else if (key == "sh" || key == "setup") c.steps.emplace_back(key, value);
    else if (key == "env") c.env.push_back(value);
    else if (key == "expect") c.expect.push_back(value);
    else if (key == "expect_once") c.expect_once.push_back(value);
    else if (key == "reject") c.reject.push_back(value);
    else if (key == "absent") c.absent.push_back(value);
    else if (key == "exists") c.exists.push_back(value);
    else if (key == "allow_new") c.allow_new.push_back(value);
    else if (key == "utf8") c.utf8.push_back(value);
    else if (key == "file_contains" || key == "max_size") {
      const auto sp = value.find(' ');
      if (sp == std::string::npos) {
        fail(key + " needs 'PATH VALUE'");
        continue;
      }
      if (key == "file_contains") c.file_contains.emplace_back(value.substr(0, sp), trim(value.substr(sp)));
      else c.max_size.emplace_back(value.substr(0, sp), std::stol(value.substr(sp)));
    } else {
      fail("unknown directive '" + key + "'");
    }
  }
  return out;
}

struct Outcome {
  int exit_code = -1;
  int signal = 0;
  bool timed_out = false;
  double seconds = 0;
  std::string output;
};

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// Runs argv in `dir` with stdin from /dev/null and stdout+stderr into a pipe read here, as a terminal or CI log
/// would (a command's left-over child holding a pipe open is part of what is tested), in its own process group;
/// the group is killed at the deadline. Reading stops when the command exits, not at end of file. Everything the
/// child needs is prepared before fork (cases run on several threads: the child may only call async-signal-safe
/// functions).
Outcome run(const std::vector<std::string>& argv, const fs::path& dir, const std::vector<std::string>& env,
            double timeout) {
  std::vector<std::string> envs;
  for (char** e = environ; *e; ++e) envs.emplace_back(*e);
  for (const auto& e : env) {
    const std::string name = e.substr(0, e.find('='));
    envs.erase(std::remove_if(envs.begin(), envs.end(), [&](const std::string& x) { return x.rfind(name + "=", 0) == 0; }),
               envs.end());
    if (e.find('=') != std::string::npos) envs.push_back(e);
  }
  std::vector<char*> a, ev;
  for (const auto& x : argv) a.push_back(const_cast<char*>(x.c_str()));
  a.push_back(nullptr);
  for (const auto& x : envs) ev.push_back(const_cast<char*>(x.c_str()));
  ev.push_back(nullptr);
  const std::string dir_s = dir.string();
  int fds[2];
  if (pipe2(fds, O_CLOEXEC) != 0) return Outcome{};
  const auto t0 = std::chrono::steady_clock::now();
  const pid_t pid = fork();
  if (pid == 0) {
    setpgid(0, 0);
    if (chdir(dir_s.c_str()) != 0) _exit(126);
    const int in = ::open("/dev/null", O_RDONLY);
    if (in < 0) _exit(126);
    dup2(in, 0);
    dup2(fds[1], 1);
    dup2(fds[1], 2);
    execve(a[0], a.data(), ev.data());
    _exit(127);
  }
  close(fds[1]);
  fcntl(fds[0], F_SETFL, O_NONBLOCK);
  Outcome o;
  constexpr std::size_t kKeep = 16u << 20;  // bytes of output kept (a runaway answer must not exhaust memory)
  auto drain = [&] {
    char buf[65536];
    for (ssize_t n; (n = read(fds[0], buf, sizeof buf)) > 0;)
      if (o.output.size() < kKeep) o.output.append(buf, static_cast<std::size_t>(n));
  };
  int status = 0;
  const auto deadline = t0 + std::chrono::duration<double>(timeout);
  for (;;) {
    pollfd p{fds[0], POLLIN, 0};
    poll(&p, 1, 5);
    drain();
    if (waitpid(pid, &status, WNOHANG) == pid) break;
    if (std::chrono::steady_clock::now() > deadline) {
      o.timed_out = true;
      kill(-pid, SIGKILL);
      kill(pid, SIGKILL);
      waitpid(pid, &status, 0);
      break;
    }
  }
  drain();
  close(fds[0]);
  kill(-pid, SIGKILL);  // whatever the command left in its group (external commands' children)
  if (WIFEXITED(status)) o.exit_code = WEXITSTATUS(status);
  if (WIFSIGNALED(status)) o.signal = WTERMSIG(status);
  o.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return o;
}

std::set<std::string> listing(const fs::path& dir) {
  std::set<std::string> out;
  std::error_code ec;
  for (auto it = fs::recursive_directory_iterator(dir, fs::directory_options::skip_permission_denied, ec);
       !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
    out.insert(fs::relative(it->path(), dir, ec).string());
    if (it->is_symlink(ec)) it.disable_recursion_pending();
  }
  return out;
}

bool valid_utf8(const std::string& s) {
  for (std::size_t i = 0; i < s.size();) {
    const unsigned char c = static_cast<unsigned char>(s[i]);
    const int n = c < 0x80 ? 0 : (c >> 5) == 6 ? 1 : (c >> 4) == 14 ? 2 : (c >> 3) == 30 ? 3 : -1;
    if (n < 0 || i + static_cast<std::size_t>(n) >= s.size() + (n == 0 ? 1 : 0)) return false;
    for (int k = 1; k <= n; ++k)
      if ((static_cast<unsigned char>(s[i + k]) >> 6) != 2) return false;
    i += static_cast<std::size_t>(n) + 1;
  }
  return true;
}

std::string excerpt(const std::string& s) {
  return s.size() <= 1500 ? s : s.substr(0, 700) + "\n[...]\n" + s.substr(s.size() - 700);
}

struct Result {
  std::vector<std::string> bad;  ///< every failure, empty when the case passed
  double seconds = 0;
};

/// Runs one case and checks it.
Result check_case(const Case& c, const fs::path& root, const std::map<std::string, std::string>& vars) {
  Result result;
  std::vector<std::string>& bad = result.bad;
  const auto t0 = std::chrono::steady_clock::now();
  std::string safe = c.name;
  for (char& ch : safe)
    if (!std::isalnum(static_cast<unsigned char>(ch)) && ch != '-' && ch != '_') ch = '_';
  const fs::path dir = root / safe;
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::map<std::string, std::string> v = vars;
  v["{dir}"] = dir.string();
  for (const auto& f : c.files) {
    const fs::path p = dir / f.path;
    fs::create_directories(p.parent_path());
    std::ofstream(p, std::ios::binary) << substitute(f.text, v);
    if (f.executable) fs::permissions(p, fs::perms::owner_all | fs::perms::group_read | fs::perms::others_read);
  }
  std::vector<std::string> env;
  for (const auto& e : c.env) env.push_back(substitute(e, v));
  for (const auto& [kind, s] : c.steps) {
    std::vector<std::string> argv = {"/bin/sh", "-c", substitute(s, v)};
    if (kind == "setup") {
      argv = split_args(substitute(s, v));
      argv.insert(argv.begin(), vars.at("{varbo}"));
    }
    const Outcome o = run(argv, dir, env, 60);
    if (o.exit_code != 0) {
      bad.push_back(kind + ": " + s + " failed (exit " + std::to_string(o.exit_code) + "): " + excerpt(o.output));
      return result;
    }
  }
  const std::set<std::string> before = listing(dir);
  std::vector<std::string> argv = split_args(substitute(c.cmd, v));
  argv.insert(argv.begin(), vars.at("{varbo}"));
#ifdef VARBO_CASE_TIMEOUT_SCALE
  const double timeout = c.timeout * VARBO_CASE_TIMEOUT_SCALE;  // ASan + UBSan build
#else
  const double timeout = c.timeout;
#endif
  const Outcome o = run(argv, dir, env, timeout);
  const std::string where = "\n--- output ---\n" + excerpt(o.output);
  if (o.timed_out) bad.push_back("hang: no exit within " + std::to_string(timeout) + " s" + where);
  else if (o.signal) bad.push_back("crash: killed by signal " + std::to_string(o.signal) + " (" + strsignal(o.signal) + ")" + where);
  else if (o.exit_code != c.exit_code)
    bad.push_back("exit " + std::to_string(o.exit_code) + ", expected " + std::to_string(c.exit_code) + where);
  for (const char* crash : {"internal error", "AddressSanitizer", "LeakSanitizer", "runtime error:", "terminate called"})
    if (o.output.find(crash) != std::string::npos) bad.push_back(std::string("crash: output says '") + crash + "'" + where);
  for (const auto& e : c.expect)
    if (o.output.find(substitute(e, v)) == std::string::npos) bad.push_back("message lacks '" + substitute(e, v) + "'" + where);
  for (const auto& e : c.expect_once) {
    const std::string text = substitute(e, v);
    const std::size_t first = o.output.find(text);
    if (first == std::string::npos) bad.push_back("message lacks '" + text + "'" + where);
    else if (o.output.find(text, first + 1) != std::string::npos) bad.push_back("message repeats '" + text + "'" + where);
  }
  for (const auto& e : c.reject)
    if (o.output.find(substitute(e, v)) != std::string::npos) bad.push_back("message has '" + substitute(e, v) + "'" + where);
  for (const auto& p : c.absent)
    if (std::error_code ec; fs::exists(fs::symlink_status(dir / p, ec))) bad.push_back("partial state: " + p + " exists");
  for (const auto& p : c.exists)
    if (std::error_code ec; !fs::exists(dir / p, ec)) bad.push_back("missing: " + p);
  for (const auto& [p, text] : c.file_contains)
    if (read_text(dir / p).find(substitute(text, v)) == std::string::npos) bad.push_back(p + " lacks '" + text + "'");
  for (const auto& [p, n] : c.max_size)
    if (std::error_code ec; fs::file_size(dir / p, ec) > static_cast<std::uintmax_t>(n) && !ec)
      bad.push_back(p + " is " + std::to_string(fs::file_size(dir / p)) + " bytes, more than " + std::to_string(n));
  for (const auto& p : c.utf8)
    if (!valid_utf8(read_text(dir / p))) bad.push_back(p + " is not valid UTF-8");
  if (c.exit_code != 0) {
    // A rejected command must leave its folder as it found it (SQLite's -wal/-shm of an existing file aside).
    for (const auto& p : listing(dir)) {
      if (before.count(p)) continue;
      bool allowed = false;
      for (const auto& a : c.allow_new) allowed |= p.rfind(a, 0) == 0;
      for (const char* side : {"-wal", "-shm", "-journal"}) {
        const std::string s = side;
        if (p.size() > s.size() && p.compare(p.size() - s.size(), s.size(), s) == 0 &&
            before.count(p.substr(0, p.size() - s.size())))
          allowed = true;
      }
      if (!allowed) bad.push_back("partial state: the rejected command created " + p);
    }
  }
  if (bad.empty()) {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return result;
}

}  // namespace

TEST_CASE("bad-input corpus: clear errors, no crash, no hang, no partial state") {
  const fs::path cases_dir = VARBO_BAD_INPUTS_DIR;
  const fs::path root = fs::path(VARBO_BINARY_DIR) / "test-runs" / "bad_inputs";
  fs::remove_all(root);
  fs::create_directories(root);
  const std::map<std::string, std::string> vars = {{"{varbo}", VARBO_EXE},
                                                   {"{fixtures}", VARBO_FIXTURE_DIR},
                                                   {"{plugins}", VARBO_PLUGIN_DIR},
                                                   {"{source}", VARBO_SOURCE_DIR}};
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(cases_dir))
    if (e.path().extension() == ".cases") files.push_back(e.path());
  std::sort(files.begin(), files.end());
  // VARBO_CASE=substring runs only the matching cases (and pending ones too, to check a fix).
  const char* only = std::getenv("VARBO_CASE");
  std::vector<Case> selected_cases;
  int pending = 0;
  std::map<std::string, int> per_file;
  std::vector<std::string> pending_names;
  std::set<std::string> names;
  for (const auto& f : files) {
    for (Case& c : parse_cases(f)) {
      if (!names.insert(c.name).second) FAIL_CHECK(c.source << ": duplicate case name " << c.name);
      if (c.cmd.empty()) FAIL_CHECK(c.source << ": case " << c.name << " has no cmd:");
      if (only && c.name.find(only) == std::string::npos) continue;
      ++per_file[f.stem().string()];
      if (!c.pending.empty() && !only) {
        ++pending;
        pending_names.push_back(c.name + " (" + c.pending + ")");
        continue;
      }
      selected_cases.push_back(std::move(c));
    }
  }
  // A VARBO_CASE that matches nothing ran nothing and passed: a typo looked like a fixed case.
  if (only && selected_cases.empty()) FAIL_CHECK("VARBO_CASE=" << std::string(only) << " matches no case");
  // Cases are independent (own folder, own process group): a few at a time, as most of them wait on a child.
  const int jobs = std::max(1, std::atoi(std::getenv("VARBO_CASE_JOBS") ? std::getenv("VARBO_CASE_JOBS") : "8"));
  std::vector<Result> results(selected_cases.size());
  std::atomic<std::size_t> next{0};
  std::vector<std::thread> workers;
  for (int w = 0; w < jobs; ++w)
    workers.emplace_back([&] {
      for (std::size_t i; (i = next++) < selected_cases.size();) results[i] = check_case(selected_cases[i], root, vars);
    });
  for (auto& t : workers) t.join();
  int passed = 0, failed = 0;
  std::vector<std::pair<double, std::string>> slowest;
  for (std::size_t i = 0; i < selected_cases.size(); ++i) {
    const Case& c = selected_cases[i];
    slowest.emplace_back(results[i].seconds, c.name);
    if (results[i].bad.empty()) {
      ++passed;
      continue;
    }
    ++failed;
    std::string all;
    for (const auto& b : results[i].bad) all += "  - " + b + "\n";
    FAIL_CHECK(c.source << ": case " << c.name << (c.pending.empty() ? "" : " [pending: " + c.pending + "]")
                        << "\n  cmd: " << c.cmd << "\n" << all);
  }
  std::sort(slowest.rbegin(), slowest.rend());
  std::printf("bad-input corpus: %d passed, %d failed, %d pending (skipped until their fix is merged); %d jobs\n",
              passed, failed, pending, jobs);
  for (const auto& [file, n] : per_file) std::printf("  %-14s %d cases\n", file.c_str(), n);
  for (std::size_t i = 0; i < std::min<std::size_t>(5, slowest.size()); ++i)
    std::printf("  slow: %-45s %.2f s\n", slowest[i].second.c_str(), slowest[i].first);
  for (const auto& p : pending_names) std::printf("  pending: %s\n", p.c_str());
  if (!only) CHECK(passed + pending + failed >= 150);
}
