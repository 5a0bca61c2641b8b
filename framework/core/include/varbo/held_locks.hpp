#pragma once
// The run locks this process holds (run_lock.hpp), for the processes that supervise its trials: a trial's
// supervisor (the external task) keeps them open until the command it stops is gone. Killed by SIGKILL, `varbo
// run` released its lock at once while its last trial's command was still in its grace period, and a `--resume`
// started the next trial beside it (two commands on one robot; red team, session 34).
#include <vector>

namespace varbo {

/// Registers / unregisters a descriptor that holds a lock (flock) of this process. At most kMaxHeldLocks are kept.
void hold_lock_in_trials(int fd);
void release_lock_from_trials(int fd);
/// The registered descriptors now (prepared before a fork: the child may keep them open).
std::vector<int> locks_held_for_trials();

constexpr int kMaxHeldLocks = 4;  // a study's and a run folder's lock files, the store guard (store_guard.hpp)

}  // namespace varbo
