#include "console/operator_actions.h"

namespace hapticlab::console {
namespace {

db::OpenOptions writer_options() {
  db::OpenOptions o;
  o.recover = false;  // never abort another process's running trial
  o.integrity = db::OpenOptions::Integrity::kSkip;  // `study check` does it; the console only appends
  return o;
}

}  // namespace

OperatorActions::OperatorActions(const std::filesystem::path& db) : db_(db, writer_options()) {}

void OperatorActions::record(db::OperatorActionRow action) {
  if (action.unix_s == 0.0) action.unix_s = db::unix_now_s();  // STOP brings the time it acted
  std::lock_guard lock(mutex_);
  // One INSERT in autocommit mode: committed (WAL, synchronous = NORMAL:
  // it survives a killed process) when add_operator_action returns.
  db_.add_operator_action(action);
}

}  // namespace hapticlab::console
