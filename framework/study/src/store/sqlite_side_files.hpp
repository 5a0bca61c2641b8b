#pragma once
// The -wal and -shm files SQLite keeps beside a study, when they belong to another user of a shared lab machine.
#include <string>

namespace varbo {

/// For a study file this user can write: its -wal or -shm that this user cannot write (another user's, their mode
/// copied from the study's before it was made group-writable, or made by a reader of an unshared study) made every
/// write fail as "attempt to write a readonly database" (red team, session 29). Such files are removed when they
/// hold no data (the -wal is empty or gone) and no process has the study open; otherwise the returned text says
/// why the study cannot be written now: whose files they are and what clears them. "" when nothing is in the way.
std::string clear_foreign_side_files(const std::string& study_path);

/// Throws InputError naming the file when the study's -journal, -wal or -shm exists and is not a plain file (a
/// FIFO, a directory, a socket or a symbolic link, the name itself: lstat). SQLite opens them by name: a FIFO
/// named study.db-journal made every command on the run hang in open(), past the first Ctrl-C (red team,
/// session 37); through a link it would write another file. Checked beside the name given and beside the file a
/// symbolic link to the study leads to (SQLite names the journal after the resolved name).
void require_plain_side_files(const std::string& study_path);

}  // namespace varbo
