#include "run_writer.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <locale>
#include <nlohmann/json.hpp>
#include <regex>

#include "varbo/config.hpp"
#include "varbo/csv.hpp"
#include "varbo/errors.hpp"
#include "varbo/log.hpp"
#include "varbo/text.hpp"

namespace fs = std::filesystem;

namespace varbo {

// A file written aside is a new file: a symbolic link planted under its name (a run folder another user can
// write) was followed, and a victim's ~/.bashrc became trials.csv (red team, session 30). The name is removed
// (the link, not its target), created exclusively without following links, and opened through the descriptor.
static void open_fresh(std::ofstream& out, const std::string& path) {
  std::error_code ec;
  fs::remove(path, ec);
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0666);
  if (fd < 0) {
    out.setstate(std::ios::failbit);  // the caller reports errno
    return;
  }
  out.open("/proc/self/fd/" + std::to_string(fd), std::ios::out | std::ios::trunc);
  if (!out.is_open()) out.open(path, std::ios::out | std::ios::trunc);  // no /proc: the file just made
  // Integers written with << (a trial's index, a fit's iteration) in the "C" locale: under a host's global
  // en_US locale, trial 1000 was "1,000", a 13th field in trials.csv (red team, session 31).
  out.imbue(std::locale::classic());
  const int saved = errno;
  ::close(fd);
  errno = saved;
}

namespace {
/// A scalar as YAML 1.1 readers (PyYAML's safe_load, ROS 1's rosparam) read it back and dump it again, where that
/// is not the text written: the resolved configuration loaded, edited and dumped in Python came back with
/// `feasible_region: false` (refused) and labels changed in silence (`on` → true, `.1` → 0.1), and its 1e-10 read
/// as a string (red team, session 30). Such scalars are written quoted: what a YAML 1.1 reader then sees is the text
/// varbo wrote, which varbo reads back the same (a real option takes a quoted number; a label stays that label).
bool yaml11_rereads_otherwise(const std::string& v) {
  static const std::regex words(
      "y|Y|yes|Yes|YES|n|N|no|No|NO|on|On|ON|off|Off|OFF|True|TRUE|False|FALSE|~|null|Null|NULL|"
      "\\.(inf|Inf|INF|nan|NaN|NAN)|[-+]\\.(inf|Inf|INF)");
  // Numbers YAML 1.1 reads but would dump in another form: a leading '+', a leading or trailing dot, leading zeros
  // (octal in 1.1), '_' separators, hexadecimal or octal, base 60 ("1:30" is 90).
  // ... and exponents without YAML 1.1's dot and sign ("1e-10" is a string to it, "1e3" too).
  static const std::regex numbers(
      "[-+]?(\\.[0-9_]+([eE][-+]?[0-9]+)?|[0-9][0-9_]*\\.([eE][-+]?[0-9]+)?|0[0-9_]+|[0-9]*_[0-9_]*(\\.[0-9_]*)?|"
      "0x[0-9a-fA-F_]+|0o?[0-7_]+|[0-9][0-9_]*(:[0-5]?[0-9])+(\\.[0-9_]*)?|[0-9]+[eE][-+]?[0-9]+|"
      "[0-9]+\\.[0-9]*[eE][0-9]+)|\\+[0-9][0-9_]*(\\.[0-9_]*)?([eE][-+]?[0-9]+)?");
  return std::regex_match(v, words) || std::regex_match(v, numbers);
}

void emit_portable(YAML::Emitter& em, const YAML::Node& n) {
  switch (n.Type()) {
    case YAML::NodeType::Map:
      em << YAML::BeginMap;
      for (const auto& kv : n) {
        em << YAML::Key;
        emit_portable(em, kv.first);
        em << YAML::Value;
        emit_portable(em, kv.second);
      }
      em << YAML::EndMap;
      break;
    case YAML::NodeType::Sequence: {
      bool scalars = true;  // a list of numbers or labels on one line; of maps (parameters:), one per line
      for (const auto& item : n) scalars = scalars && item.IsScalar();
      if (scalars) em << YAML::Flow;
      em << YAML::BeginSeq;
      for (const auto& item : n) emit_portable(em, item);
      em << YAML::EndSeq;
      break;
    }
    case YAML::NodeType::Scalar: {
      const std::string v = n.Scalar();
      if (n.Tag() == "!" || yaml11_rereads_otherwise(v)) em << YAML::DoubleQuoted << v;  // "!": quoted in the source
      else em << v;
      break;
    }
    default:
      em << YAML::Null;
  }
}
}  // namespace

// Names and error messages: one valid UTF-8 line per cell, whatever a task wrote (varbo/csv.hpp).
static std::string csv_escape(const std::string& s) { return csv_text(s); }

namespace {
/// FNV-1a, 64 bits: a checksum of what varbo wrote (not a security measure).
std::uint64_t fnv1a64(const std::string& text) {
  std::uint64_t h = 14695981039346656037ull;
  for (const unsigned char c : text) h = (h ^ c) * 1099511628211ull;
  return h;
}

/// Says so when `path`, written by varbo with a checksum line, was edited since: the first key whose value differs
/// from what is written now, and how to carry a budget (the one change a resume takes, through --budget).
void warn_if_edited(const std::string& path, const std::string& body_now) {
  std::ifstream in(path);
  if (!in) return;
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string marker = "; checksum ";
  const std::size_t at = text.rfind(marker);
  const std::size_t first = text.find('\n');
  const std::size_t last_line = text.rfind("\n#", at);
  if (at == std::string::npos || first == std::string::npos || last_line == std::string::npos || last_line < first)
    return;  // not written with a checksum (an older varbo): nothing to compare
  const std::string body = text.substr(first + 1, last_line + 1 - (first + 1));
  const std::string sum = text.substr(at + marker.size(), 16);
  if (fmt::format("{:016x}", fnv1a64(body)) == sum) return;
  std::string where;
  try {
    const YAML::Node was = YAML::Load(body), now = YAML::Load(body_now);
    if (was.IsMap() && now.IsMap())
      for (const auto& kv : was) {
        const std::string key = kv.first.as<std::string>();
        if (!now[key] || YAML::Dump(now[key]) != YAML::Dump(kv.second)) {
          where = fmt::format(" (at {}: '{}', the study's '{}')", key, safe_text(YAML::Dump(kv.second), 80),
                              now[key] ? safe_text(YAML::Dump(now[key]), 80) : std::string("none"));
          break;
        }
      }
  } catch (const YAML::Exception&) {
    where = " (it no longer parses)";
  }
  log_warn("{} was edited since varbo wrote it{}; a resumed run continues the study as stored and rewrites this file "
           "(a budget is raised with `--resume DIR --budget N`; another change is a new study: `varbo run` on the "
           "edited file with another -o)",
           path, where);
}
}  // namespace

RunWriter::RunWriter(const std::string& folder, const StudyConfig& study, const Domain& domain,
                     std::vector<std::string> component_names, bool with_regret, SharedSpace space,
                     const std::vector<std::string>& plugin_paths)
    : folder_(folder), components_(std::move(component_names)), with_regret_(with_regret), space_(std::move(space)) {
  std::error_code ec;
  fs::create_directories(folder_, ec);
  if (ec) throw InputError(fmt::format("{}: cannot create the run folder: {}", folder_, ec.message()));
  remove_stale_asides();
  {
    // Written aside and renamed into place, as trials.csv and model.yaml (publish()): a reader (`varbo select`,
    // `plot`, a backup) during a `--resume` saw these files empty or torn (red team, session 28).
    std::ofstream cfg;
    open_fresh(cfg, aside("config.resolved.yaml"));
    YAML::Emitter em;
    YAML::Node resolved = study.resolved();
    // Not part of StudyConfig::resolved() (the study's identity): where the plugins are is not what the study is.
    // Left out, the file named components no varbo process could find (`varbo select` on the run: "unknown task").
    if (!plugin_paths.empty()) {
      const fs::path here = fs::absolute(folder_, ec).lexically_normal();
      YAML::Node list(YAML::NodeType::Sequence);
      for (const std::string& p : plugin_paths) {
        const fs::path rel = ec ? fs::path{} : fs::path(p).lexically_relative(here);
        list.push_back(rel.empty() ? p : rel.string());
      }
      resolved["plugin_path"] = list;
    }
    // `description` ("free text, copied to the run folder") was copied nowhere (red team, session 30). Not part of
    // resolved(), the study's identity: a note edited between sessions is not another study.
    const ConfigNode description = study.source.child("description");
    if (description.defined() && description.is_scalar()) {
      description_ = description.scalar();
      resolved["description"] = description_;
    }
    emit_portable(em, resolved);
    const std::string body = std::string(em.c_str()) + "\n";
    // Edited by hand and then resumed, the file was replaced by the study's configuration in silence: a budget
    // raised in it was dropped (audit, session 48). The last line holds a checksum of what varbo wrote; a file
    // whose body no longer matches it was edited, and the edit is said before the file is rewritten.
    const std::string sum = fmt::format("{:016x}", fnv1a64(body));
    warn_if_edited(folder_ + "/config.resolved.yaml", body);
    cfg << "# varbo resolved configuration: every default filled in. Re-run with `varbo run` on this file.\n"
        << body << "# written by varbo (a resumed run rewrites this file from the study; edits here are not read by "
        << "--resume); checksum " << sum << "\n";
    cfg.close();
    // A full disk (the run folder apart from the study): the run goes on, its files of before kept.
    if (cfg) fs::rename(aside("config.resolved.yaml"), folder_ + "/config.resolved.yaml", ec);
    if (!cfg || ec) {
      log_warn("{}/config.resolved.yaml: cannot write{}; the previous one, if any, is kept", folder_,
               ec ? ": " + ec.message() : std::string());
      fs::remove(aside("config.resolved.yaml"), ec);
    }
  }
  open_fresh(trials_, aside("trials.csv"));
  if (!trials_)
    throw InputError(fmt::format("{}: cannot write ({})", aside("trials.csv"), std::strerror(errno)));
  trials_ << "index,phase";
  for (const auto& n : domain.names) trials_ << "," << csv_escape(n);
  trials_ << ",cost,ok";
  for (const auto& c : components_) trials_ << "," << csv_escape(c);
  trials_ << ",fit_seconds,acquisition_seconds,evaluation_seconds,error";
  if (with_regret_) trials_ << ",regret_best_observed,regret_recommended";
  trials_ << "\n";
  trials_.flush();
  open_fresh(model_, aside("model.yaml"));
  model_ << "# hyperparameters after each fit\n";
  model_.flush();
}

// Files a killed run was writing aside (NAME.tmp.PID) stayed in the folder for good, one set per SIGKILL
// (red team, session 29). This process holds the run folder's lock (study_run.cpp), so every other writer of
// these names is dead: their asides are removed. Only the names this class writes, with a pid that is not ours.
void RunWriter::remove_stale_asides() const {
  std::error_code ec;
  const std::string own = std::to_string(static_cast<long>(::getpid()));
  for (fs::directory_iterator it(folder_, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string file = it->path().filename().string();
    for (const char* name : {"config.resolved.yaml", "trials.csv", "model.yaml", "summary.json"}) {
      const std::string prefix = std::string(name) + ".tmp.";
      if (file.size() <= prefix.size() || file.compare(0, prefix.size(), prefix) != 0) continue;
      const std::string pid = file.substr(prefix.size());
      if (pid.find_first_not_of("0123456789") != std::string::npos || pid == own) continue;
      std::error_code rm;
      if (it->is_regular_file(rm)) fs::remove(it->path(), rm);
    }
  }
}

std::string RunWriter::aside(const std::string& name) const {
  return fmt::format("{}/{}.tmp.{}", folder_, name, static_cast<long>(::getpid()));
}

void RunWriter::publish() {
  if (published_) return;
  published_ = true;
  trials_.flush();
  model_.flush();
  // The streams stay open on the renamed files: later rows are appended to what readers now see. One that could
  // not be written whole (a full disk) does not replace the complete file of before.
  for (auto [name, stream] : {std::pair<const char*, std::ofstream*>{"trials.csv", &trials_}, {"model.yaml", &model_}}) {
    std::error_code ec;
    if (*stream) fs::rename(aside(name), folder_ + "/" + name, ec);
    if (!*stream || ec) {
      log_warn("{}/{}: cannot write{}; the previous one, if any, is kept", folder_, name,
               ec ? ": " + ec.message() : std::string());
      fs::remove(aside(name), ec);
    }
  }
}

RunWriter::~RunWriter() {
  if (published_) return;
  // Never published (the run stopped while rewriting them): the files of before stay as they were.
  std::error_code ec;
  for (const char* name : {"trials.csv", "model.yaml"}) fs::remove(aside(name), ec);
}

void RunWriter::trial(const TrialRow& r) {
  const TrialRecord& t = r.trial;
  trials_ << r.index << "," << csv_escape(t.phase);  // a plugin's phase text may hold ',', '"' or a newline
  for (Index i = 0; i < t.theta.size(); ++i)  // labels for categories, integers as integers
    trials_ << "," << (space_ ? csv_escape(space_->format_value(static_cast<std::size_t>(i), t.theta[i])) : exact(t.theta[i]));
  trials_ << "," << (r.ok() ? exact(t.cost) : std::string("nan")) << "," << (r.ok() ? 1 : 0);
  std::vector<std::string> missing;
  for (const auto& c : components_) {
    std::string v = "nan";
    bool reported = false;
    for (const auto& kv : t.components)
      if (kv.first == c) v = exact(kv.second), reported = true;
    trials_ << "," << v;
    if (r.ok() && !reported && std::find(warned_missing_.begin(), warned_missing_.end(), c) == warned_missing_.end())
      missing.push_back("'" + c + "'");
  }
  if (!missing.empty()) {
    // A declared component a successful trial did not report was written as nan without a word; the run went on,
    // and `varbo rescore` found out at the end ("no successful trials with all components"; audit, session 48). A
    // rig that drops a channel is said at once, once per component.
    log_warn("trial {}: declared cost component{} {} not reported by the task; recorded as missing (nan): `varbo "
             "rescore` leaves such trials out (said once per component)",
             t.id, missing.size() > 1 ? "s" : "", safe_text(join(missing), 300));
    for (const auto& c : components_)
      if (std::find(missing.begin(), missing.end(), "'" + c + "'") != missing.end()) warned_missing_.push_back(c);
  }
  if (!warned_extra_) {
    // One warning, the first name bounded and escaped: the names come from the command's answer, and one
    // warning per name printed 50,000 lines for an answer of 50,000 components, a 1 MB name whole.
    std::size_t unknown = 0;
    std::string first;
    for (const auto& kv : t.components) {
      bool known = false;
      for (const auto& c : components_) known = known || c == kv.first;
      if (!known && unknown++ == 0) first = kv.first;
    }
    if (unknown > 0) {
      log_warn("task reported an undeclared cost component '{}'{}; it is not recorded in trials.csv (declare the "
               "components with the task's `components: [...]`: external and python tasks take it)",
               safe_text(first, 100), unknown > 1 ? fmt::format(" and {} more", unknown - 1) : std::string());
      warned_extra_ = true;
    }
  }
  trials_ << "," << fmt::format("{:.6f},{:.6f},{:.6f}", t.fit_seconds, t.acquisition_seconds, t.evaluation_seconds)
          << "," << csv_escape(t.error);
  if (with_regret_) trials_ << "," << exact(r.regret_best_observed) << "," << exact(r.regret_recommended);
  trials_ << "\n";
  errno = 0;
  trials_.flush();
  if (!trials_ && !trials_warned_) {  // a full disk: the study holds the trial; the table does not (said once)
    // errno as the failed write left it ("cannot write (Success)" on a full disk read it after it was reset).
    const int err = errno;
    log_warn("{}/trials.csv: cannot write ({}); the study file keeps every trial: `varbo export` writes the table",
             folder_, err ? std::strerror(err) : "a write failed");
    trials_warned_ = true;
  }
}

namespace {
/// A number of model.yaml as YAML reads it: .inf / -.inf / .nan, not "inf" (a string to a YAML reader).
std::string yaml_number(double v) {
  if (std::isnan(v)) return ".nan";
  if (std::isinf(v)) return v > 0 ? ".inf" : "-.inf";
  return exact(v);
}
}  // namespace

void RunWriter::model(const ModelSnapshot& s) {
  model_ << "- iteration: " << s.iteration << "\n  objective: " << yaml_number(s.objective) << "\n";
  if (!s.note.empty()) model_ << "  note: \"" << s.note << "\"\n";
  if (!s.region_state.empty()) {
    std::string r = s.region_state;  // YAML double-quoted scalar: escape backslashes and quotes
    for (std::size_t i = 0; i < r.size(); ++i)
      if (r[i] == '\\' || r[i] == '"') r.insert(i++, 1, '\\');
    model_ << "  region: \"" << r << "\"\n";
  }
  model_ << "  hyperparameters:\n";
  for (const auto& h : s.hyperparameters) model_ << "    \"" << h.name << "\": " << yaml_number(h.value) << "\n";
  model_.flush();
}

static nlohmann::json vec_json(const Vec& v) {
  nlohmann::json a = nlohmann::json::array();
  for (Index i = 0; i < v.size(); ++i) a.push_back(v[i]);
  return a;
}

void RunWriter::summary(const RunSummary& s, const Domain& domain, const std::optional<Optimum>& optimum) {
  nlohmann::json j;
  if (!study_.empty()) j["study"] = study_;
  j["evaluations"] = s.evaluations;
  j["failed"] = s.failed;
  // Share of the trials that failed (no cost): on a robot, how often it fell; 0 before any trial.
  j["failure_rate"] = s.evaluations > 0 ? static_cast<double>(s.failed) / static_cast<double>(s.evaluations) : 0.0;
  j["parameter_names"] = domain.names;
  if (s.best_theta) {
    j["best_theta"] = vec_json(*s.best_theta);
    j["best_cost"] = s.best_cost;
  }
  if (s.recommended_theta) j["recommended_theta"] = vec_json(*s.recommended_theta);
  // Named, typed values (labels for categories) beside the θ vectors, when the study declares parameters.
  if (space_) {
    if (s.best_theta) j["best_params"] = nlohmann::json::parse(space_->params(*s.best_theta).to_json());
    if (s.recommended_theta) j["recommended_params"] = nlohmann::json::parse(space_->params(*s.recommended_theta).to_json());
  }
  if (optimum) j["known_optimum"] = optimum->cost;
  if (!s.recommendation_rule.empty()) j["recommendation_rule"] = s.recommendation_rule;
  // Where the optimum is known: the regret of what the run recommends (what a user deploys) and the oracle
  // figure of the best evaluated θ (a user of a noisy task cannot know which one that is).
  if (s.regret_recommended) j["regret_recommended"] = *s.regret_recommended;
  if (s.regret_best_observed) j["regret_best_observed"] = *s.regret_best_observed;
  j["seconds"] = s.seconds;
  if (!description_.empty()) j["description"] = description_;
  const std::string tmp = aside("summary.json");
  bool written = false;
  int err = 0;  // errno of the first failed step, read before anything else can change it
  {
    std::ofstream out;
    errno = 0;
    open_fresh(out, tmp);
    if (!out) err = errno;
    out << j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) << "\n";
    out.flush();
    if (!out && err == 0) err = errno;
    written = static_cast<bool>(out);
    out.close();
    if (out.fail() && err == 0) err = errno;
    written = written && !out.fail();
  }
  std::error_code ec;
  // A full disk wrote an empty temporary file, which replaced the good summary.json (and with it the study's name
  // that guards the folder) with exit 0 (red team, session 25): keep the last complete one and say so. The reason
  // is the failed step's errno: read after the removal below it said "No such file or directory" for a folder
  // made read-only (red team, session 46).
  if (!written) {
    fs::remove(tmp, ec);
    if (!summary_warned_)
      log_warn("{}/summary.json: cannot write ({}); the previous one is kept, the study itself holds every trial",
               folder_, err ? std::strerror(err) : "a write failed");
    summary_warned_ = true;
    summary_stale_ = true;
    return;
  }
  fs::rename(tmp, folder_ + "/summary.json", ec);
  if (ec) log_warn("{}/summary.json: cannot replace it ({})", folder_, ec.message());
  summary_stale_ = static_cast<bool>(ec);
}

std::vector<std::string> RunWriter::stale_files() const {
  std::vector<std::string> out;
  if (trials_warned_ || (published_ && !trials_)) out.push_back("trials.csv");
  if (summary_stale_) out.push_back("summary.json");
  return out;
}

}  // namespace varbo
