// The scenario every lock-free protocol of rtplc must survive (spec runtime.md,
// "The process image"): a reader at a higher SCHED_FIFO priority preempts the
// writer on the same CPU while the writer is in the middle of a store, and must
// still get a consistent value at once — the writer cannot run again until the
// reader gives the CPU back.
//
// run_preempting_reader() runs it in a child process (so a reader that spins
// forever is killed, not the test runner): a writer thread at FIFO 10 and a
// reader thread at FIFO 20, both pinned to CPU 0. The writer calls
// `write(preempt)`, which must call `preempt()` in the middle of its store;
// preempt() wakes the reader, which preempts the writer on the spot and runs
// `read()`. The child's exit code says what read() returned. It needs root (or
// CAP_SYS_NICE) for SCHED_FIFO; without it the result says why it was skipped.
#pragma once

#include <semaphore.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <functional>
#include <string>
#include <thread>

#include "kernel_rt/rt_thread.h"

namespace rtplc::testing {

struct PreemptionResult {
  bool ran = false;          // false: skipped, see `why`
  bool read_ok = false;      // what read() returned, while the writer was mid-store
  bool reader_preempted_writer = false;  // the writer was still mid-store when read() returned
  std::string why;
};

inline PreemptionResult run_preempting_reader(const std::function<void(const std::function<void()>&)>& write,
                                              const std::function<bool()>& read, int limit_s = 10) {
  PreemptionResult res;
  struct Shared {
    sem_t wake_reader;
    // Lock-free atomics work across the fork: the child's threads share them.
    std::atomic<int> writer_mid;      // 1 while the writer is inside its store
    std::atomic<int> read_ok;
    std::atomic<int> reader_saw_mid;  // writer_mid as the reader saw it after read()
    std::atomic<int> fifo_refused;
  };
  void* mem = mmap(nullptr, sizeof(Shared), PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0);
  if (mem == MAP_FAILED) {
    res.why = "mmap failed";
    return res;
  }
  auto* sh = new (mem) Shared{};
  sem_init(&sh->wake_reader, 1, 0);
  const pid_t child = fork();
  if (child == 0) {
    kernel_rt::ThreadSpec rs;
    rs.name = "preempt-reader";
    rs.fifo_priority = 20;
    rs.cpu = 0;
    auto reader = kernel_rt::start_thread(rs, [&] {
      while (sem_wait(&sh->wake_reader) != 0) {
      }
      sh->read_ok = read() ? 1 : 0;
      sh->reader_saw_mid = sh->writer_mid.load();
    });
    if (!reader || reader->outcome().fell_back) {
      sh->fifo_refused = 1;
      sem_post(&sh->wake_reader);
      _exit(3);
    }
    kernel_rt::ThreadSpec ws;
    ws.name = "preempt-writer";
    ws.fifo_priority = 10;
    ws.cpu = 0;
    auto writer = kernel_rt::start_thread(ws, [&] {
      write([&] {
        sh->writer_mid = 1;
        // The reader (higher priority, same CPU) becomes runnable here and
        // preempts us before this call returns.
        sem_post(&sh->wake_reader);
        sh->writer_mid = 0;
      });
    });
    if (!writer || writer->outcome().fell_back) {
      sh->fifo_refused = 1;
      _exit(3);
    }
    writer->join();
    reader->join();
    _exit(0);
  }
  int status = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(limit_s);
  while (waitpid(child, &status, WNOHANG) == 0) {
    if (std::chrono::steady_clock::now() > deadline) {
      kill(child, SIGKILL);
      waitpid(child, &status, 0);
      res.ran = true;
      res.why = "the reader never returned: it spins while the writer it preempted cannot run";
      munmap(mem, sizeof(Shared));
      return res;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  if (sh->fifo_refused) {
    res.why = "SCHED_FIFO is not allowed here (run as root or with CAP_SYS_NICE)";
  } else if (WIFEXITED(status) && WEXITSTATUS(status) == 0) {
    res.ran = true;
    res.read_ok = sh->read_ok != 0;
    res.reader_preempted_writer = sh->reader_saw_mid != 0;
  } else {
    res.why = "the scenario's child process failed (status " + std::to_string(status) + ")";
  }
  munmap(mem, sizeof(Shared));
  return res;
}

}  // namespace rtplc::testing
