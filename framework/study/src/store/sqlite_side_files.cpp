#include "sqlite_side_files.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <pwd.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <filesystem>
#include <vector>

#include "varbo/errors.hpp"
#include "varbo/log.hpp"
#include "varbo/regular_file.hpp"

namespace varbo {

namespace {

std::string user_name(uid_t uid) {
  const passwd* pw = ::getpwuid(uid);
  return pw != nullptr ? pw->pw_name : fmt::format("uid {}", uid);
}

/// Whether some process has the study open in WAL mode: every SQLite connection holds a read lock on the -shm's
/// "dead man switch" byte (SQLite's os_unix.c: UNIX_SHM_DMS, offset 128) while it lives.
bool shm_in_use(const std::string& shm) {
  const int fd = ::open(shm.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return false;
  struct flock probe {};
  probe.l_type = F_WRLCK;
  probe.l_whence = SEEK_SET;
  probe.l_start = 128;
  probe.l_len = 1;
  const bool locked = ::fcntl(fd, F_GETLK, &probe) != 0 || probe.l_type != F_UNLCK;  // unsure: in use
  ::close(fd);
  return locked;
}

}  // namespace

std::string clear_foreign_side_files(const std::string& study_path) {
  if (::access(study_path.c_str(), W_OK) != 0) return "";  // a reader: read_only_reason says why
  const std::string wal = study_path + "-wal", shm = study_path + "-shm";
  struct stat wal_st {}, shm_st {};
  const bool has_wal = ::stat(wal.c_str(), &wal_st) == 0, has_shm = ::stat(shm.c_str(), &shm_st) == 0;
  const bool wal_blocked = has_wal && ::access(wal.c_str(), W_OK) != 0;
  const bool shm_blocked = has_shm && ::access(shm.c_str(), W_OK) != 0;
  if (!wal_blocked && !shm_blocked) return "";
  const struct stat& st = wal_blocked ? wal_st : shm_st;
  const std::string& file = wal_blocked ? wal : shm;
  const std::string whose = fmt::format("{} belongs to user {} (mode {:04o})", file, user_name(st.st_uid),
                                        st.st_mode & 07777);
  const bool in_use = has_shm && shm_in_use(shm);
  if ((!has_wal || wal_st.st_size == 0) && !in_use) {
    std::error_code ec;
    std::filesystem::remove(wal, ec);
    std::filesystem::remove(shm, ec);
    if (!std::filesystem::exists(wal) && !std::filesystem::exists(shm)) {
      log_info("{}: removed SQLite's side files of another user that held no data ({})", study_path, whose);
      return "";
    }
  }
  return fmt::format("not writable by this user now: {}{}; they clear when that user opens the study once (e.g. "
                     "`varbo status`), or that user runs `chmod g+w {}*` (a study shared by a group: create it "
                     "with `umask 002`)",
                     whose, in_use ? ", and a process of theirs has the study open" : ", holding changes not yet in the study file",
                     study_path);
}

void require_plain_side_files(const std::string& study_path) {
  std::vector<std::string> names{study_path};
  std::error_code ec;
  const std::string resolved = std::filesystem::weakly_canonical(study_path, ec).string();
  if (!ec && !resolved.empty() && resolved != std::filesystem::absolute(study_path, ec).lexically_normal().string())
    names.push_back(resolved);
  for (const std::string& name : names)
    for (const char* suffix : {"-journal", "-wal", "-shm"}) {
      const std::string side = name + suffix;
      if (const auto k = irregular_entry_kind(side))
        throw InputError(fmt::format("{}: not a regular file ({}; expected SQLite's {} of the study {}, a plain "
                                     "file, or nothing); SQLite would open it: remove it",
                                     side, *k, suffix + 1, study_path));
    }
}

}  // namespace varbo
