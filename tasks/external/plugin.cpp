// libvarbo_task_external: a task evaluated by running a user command.
#include "external_factory.hpp"
#include "varbo/plugin.hpp"

VARBO_PLUGIN("task_external", "0.1.0", "Task evaluated by an external command (JSON on stdin or arguments)") {
  registry.add(varbo::make_component<varbo::Task>(
      "external",
      "runs a shell command per trial; cost = a number on the last stdout line or {\"cost\": x, "
      "\"components\": {...}}; non-zero exit, timeout or a bad answer = failed trial",
      varbo::tasks::external_options(),
      varbo::Factory<varbo::Task>([](const varbo::Options& o, const varbo::BuildContext&) {
        return varbo::tasks::make_external_task(o);
      })));
}
