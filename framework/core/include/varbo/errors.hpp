#pragma once
// The error hierarchy. Every error thrown on user input says where (file, key) and what was expected.
#include <stdexcept>
#include <string>

namespace varbo {

class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};
/// A configuration value is missing, unknown, of the wrong type or out of range.
class ConfigError : public Error { public: using Error::Error; };
/// A plugin library could not be loaded or is not a varbo plugin.
class PluginLoadError : public Error { public: using Error::Error; };
/// A plugin library was built against an incompatible ABI or API.
class PluginVersionError : public PluginLoadError { public: using PluginLoadError::PluginLoadError; };
/// A component name that no loaded plugin provides.
class UnknownComponentError : public ConfigError { public: using ConfigError::ConfigError; };
/// Numerical trouble the caller may recover from (non-PD matrix, failed fit, NaN).
class NumericalError : public Error { public: using Error::Error; };
/// Bad data files or command-line input.
class InputError : public Error { public: using Error::Error; };
/// The study file a Study opened was deleted, moved or replaced by another file: whatever was being recorded
/// belongs to the study that was there, not to the file that has the name now.
class StudyFileChangedError : public InputError { public: using InputError::InputError; };
/// A task cannot run at all (its command is not found or not executable: exit status 127 or 126 from the shell): a
/// problem of the set-up, not a result of θ. Thrown by Task::evaluate; the run or worker stops (exit 2) and the
/// trial is abandoned, not recorded as failed — ten "failures" at good points taught the failure model to avoid
/// them when a relative command was run from another folder (red team, session 26).
class TaskSetupError : public Error { public: using Error::Error; };
/// An exception that is not varbo's own came out of an algorithm or its components while a study that loads
/// third-party plugins was asked or told: the message says what was being done and which plugins those are.
class PluginCodeError : public Error { public: using Error::Error; };

}  // namespace varbo
