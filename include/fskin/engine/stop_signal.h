#pragma once
// Ctrl-C / SIGTERM handling for long jobs: the first signal only raises a flag
// so the training loop can finish its step, write a checkpoint and exit
// cleanly; a second signal terminates immediately.
namespace fskin {

class StopSignal {
 public:
  StopSignal();   // installs SIGINT and SIGTERM handlers
  ~StopSignal();  // restores the previous handlers
  StopSignal(const StopSignal&) = delete;
  StopSignal& operator=(const StopSignal&) = delete;

  bool requested() const;
  static void request();  // what the handler does; for tests
};

}  // namespace fskin
