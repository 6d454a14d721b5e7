// Tests of explicitly scheduled threads and the SCHED_OTHER fallback (kernel_rt/rt_thread.h).
#include "kernel_rt/rt_thread.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <sched.h>
#include <unistd.h>

#include <atomic>
#include <cstring>

#include "kernel_rt/process_limits.h"
#include "privilege_drop.h"

namespace rtplc::kernel_rt {
namespace {

bool fifo_permitted() {
  return probe_process_facts().fifo_obtained;
}

TEST(RtThread, fifo_thread_gets_the_policy_and_priority_it_asked_for) {
  if (!fifo_permitted()) GTEST_SKIP() << "this process may not use SCHED_FIFO";
  ThreadSpec spec;
  spec.name = "fifo-test";
  spec.fifo_priority = 10;
  SchedState inside;
  auto t = start_thread(spec, [&] { inside = current_thread_sched(); });
  ASSERT_TRUE(t.ok()) << t.error();
  const SchedOutcome out = t->outcome();
  t->join();
  EXPECT_FALSE(out.fell_back);
  EXPECT_EQ(out.fallback_reason, "");
  EXPECT_EQ(out.obtained.policy, SchedPolicy::kFifo);
  EXPECT_EQ(out.obtained.priority, 10);
  EXPECT_EQ(inside.policy, SchedPolicy::kFifo);
  EXPECT_EQ(inside.priority, 10);
}

TEST(RtThread, sched_now_reads_the_kernel_while_the_thread_runs) {
  if (!fifo_permitted()) GTEST_SKIP() << "this process may not use SCHED_FIFO";
  std::atomic<bool> stop{false};
  ThreadSpec spec;
  spec.fifo_priority = 3;
  auto t = start_thread(spec, [&] {
    while (!stop.load()) usleep(1000);
  });
  ASSERT_TRUE(t.ok()) << t.error();
  const SchedState now = t->sched_now();
  EXPECT_GT(t->tid(), 0);
  stop = true;
  t->join();
  EXPECT_EQ(now.policy, SchedPolicy::kFifo);
  EXPECT_EQ(now.priority, 3);
}

TEST(RtThread, other_thread_when_no_priority_is_asked) {
  ThreadSpec spec;
  spec.name = "plain";
  auto t = start_thread(spec, [] {});
  ASSERT_TRUE(t.ok()) << t.error();
  EXPECT_EQ(t->outcome().requested.policy, SchedPolicy::kOther);
  EXPECT_EQ(t->outcome().obtained.policy, SchedPolicy::kOther);
  EXPECT_FALSE(t->outcome().fell_back);
}

TEST(RtThread, main_thread_of_a_test_is_sched_other) {
  EXPECT_EQ(current_thread_sched().policy, SchedPolicy::kOther);
  EXPECT_STREQ(policy_name(SchedPolicy::kFifo), "SCHED_FIFO");
}

TEST(RtThread, name_is_set_and_truncated_to_the_kernel_limit) {
  ThreadSpec spec;
  spec.name = "a-very-long-thread-name-indeed";
  char seen[32] = {};
  auto t = start_thread(spec, [&] { pthread_getname_np(pthread_self(), seen, sizeof seen); });
  ASSERT_TRUE(t.ok()) << t.error();
  t->join();
  EXPECT_STREQ(seen, "a-very-long-thr");
}

TEST(RtThread, pinned_thread_runs_only_on_its_cpu) {
  const unsigned last = allowed_cpu_count() - 1;
  if (!cpu_allowed(last)) GTEST_SKIP() << "affinity mask is not contiguous from 0";
  ThreadSpec spec;
  spec.cpu = last;
  int ran_on = -1;
  int mask_count = 0;
  auto t = start_thread(spec, [&] {
    ran_on = sched_getcpu();
    cpu_set_t set;
    CPU_ZERO(&set);
    sched_getaffinity(0, sizeof set, &set);
    mask_count = CPU_COUNT(&set);
  });
  ASSERT_TRUE(t.ok()) << t.error();
  t->join();
  EXPECT_EQ(ran_on, static_cast<int>(last));
  EXPECT_EQ(mask_count, 1);
}

TEST(RtThread, impossible_requests_are_errors_not_fallbacks) {
  ThreadSpec spec;
  spec.name = "bad";
  spec.fifo_priority = 150;
  auto a = start_thread(spec, [] {});
  ASSERT_FALSE(a.ok());
  EXPECT_NE(a.error().find("outside 1..99"), std::string::npos) << a.error();

  spec.fifo_priority = 0;
  spec.cpu = 4000;
  auto b = start_thread(spec, [] {});
  ASSERT_FALSE(b.ok());
  EXPECT_NE(b.error().find("CPU 4000"), std::string::npos) << b.error();

  auto c = start_thread(ThreadSpec{}, nullptr);
  EXPECT_FALSE(c.ok());
}

TEST(RtThread, stack_prefault_that_does_not_fit_is_noted_not_fatal) {
  ThreadSpec spec;
  spec.stack_bytes = 256u << 10;
  spec.prefault_stack = 1u << 20;
  bool ran = false;
  auto t = start_thread(spec, [&] { ran = true; });
  ASSERT_TRUE(t.ok()) << t.error();
  const std::string note = t->outcome().stack_note;
  t->join();
  EXPECT_TRUE(ran);
  EXPECT_NE(note.find("larger stack"), std::string::npos) << note;

  spec.stack_bytes = 4u << 20;  // sanitizer runtimes keep much of their thread state here
  spec.prefault_stack = 256u << 10;
  auto ok = start_thread(spec, [] {});
  ASSERT_TRUE(ok.ok()) << ok.error();
  EXPECT_EQ(ok->outcome().stack_note, "");
}

TEST(RtThread, moved_thread_joins_once) {
  std::atomic<int> runs{0};
  auto t = start_thread(ThreadSpec{}, [&] { runs++; });
  ASSERT_TRUE(t.ok());
  RtThread a = std::move(t.value());
  RtThread b;
  b = std::move(a);
  EXPECT_FALSE(a.joinable());
  EXPECT_TRUE(b.joinable());
  b.join();
  EXPECT_FALSE(b.joinable());
  EXPECT_EQ(runs.load(), 1);
}

// Writes `bytes` of a frame of its own, so the stack goes at least that deep.
[[gnu::noinline]] void use_stack(size_t bytes) {
  auto* block = static_cast<volatile unsigned char*>(__builtin_alloca(bytes));
  for (size_t i = 0; i < bytes; i += 64) block[i] = static_cast<unsigned char>(i);
}

TEST(RtThread, a_thread_gets_the_default_stack_not_the_system_one) {
  auto t = start_thread(ThreadSpec{}, [] {});
  ASSERT_TRUE(t.ok()) << t.error();
  EXPECT_EQ(t->stack_bytes(), kDefaultStackBytes);
  ThreadSpec big;
  big.stack_bytes = 1u << 20;
  auto b = start_thread(big, [] {});
  ASSERT_TRUE(b.ok()) << b.error();
  EXPECT_EQ(b->stack_bytes(), 1u << 20);
}

TEST(RtThread, stack_high_water_says_how_deep_the_body_went) {
  size_t shallow = 0, deep = 0;
  for (size_t want : {size_t{0}, size_t{96} << 10}) {
    auto t = start_thread(ThreadSpec{}, [want] {
      if (want > 0) use_stack(want);
    });
    ASSERT_TRUE(t.ok()) << t.error();
    t->join();
    (want == 0 ? shallow : deep) = t->stack_high_water();
  }
  if (deep == 0) GTEST_SKIP() << "stack depth is not measured in a sanitizer build";
  EXPECT_GE(deep, size_t{96} << 10);
  EXPECT_LT(deep, kDefaultStackBytes);
  EXPECT_LT(shallow, size_t{32} << 10) << "an empty body needs only the start-up frames";
}

// What a start looked like from inside an unprivileged child, as one line.
std::string describe_start(int priority) {
  ThreadSpec spec;
  spec.name = "fallback";
  spec.fifo_priority = priority;
  SchedState inside;
  auto t = start_thread(spec, [&] { inside = current_thread_sched(); });
  if (!t) return "error: " + t.error();
  t->join();
  const auto& o = t->outcome();
  return fmt::format("{} {} fell_back={} first={} inside={} | {}", policy_name(o.obtained.policy),
                     o.obtained.priority, o.fell_back, o.first_fallback_in_process,
                     policy_name(inside.policy), o.fallback_reason);
}

TEST(RtThread, without_privilege_fifo_falls_back_to_other_and_says_so_once) {
  if (!testing::can_drop_privileges()) GTEST_SKIP() << "needs root to fork an unprivileged child";
  testing::ChildLimits limits;
  limits.rtprio = 0;
  const auto child = testing::run_unprivileged(limits, [] {
    reset_fallback_notice_for_tests();
    const std::string first = describe_start(40);
    return first + "\n" + describe_start(41);
  });
  ASSERT_TRUE(child.ran) << child.problem;
  const std::string first = child.output.substr(0, child.output.find('\n'));
  const std::string second = child.output.substr(child.output.find('\n') + 1);
  EXPECT_EQ(first.rfind("SCHED_OTHER 0 fell_back=true first=true inside=SCHED_OTHER", 0), 0u)
      << first;
  EXPECT_EQ(second.rfind("SCHED_OTHER 0 fell_back=true first=false inside=SCHED_OTHER", 0), 0u)
      << second;
  EXPECT_NE(first.find("RLIMIT_RTPRIO 0"), std::string::npos) << first;
  EXPECT_NE(first.find("LimitRTPRIO=99"), std::string::npos) << first;
}

TEST(RtThread, rtprio_limit_allows_fifo_up_to_the_limit_only) {
  if (!testing::can_drop_privileges()) GTEST_SKIP() << "needs root to fork an unprivileged child";
  testing::ChildLimits limits;
  limits.rtprio = 10;
  const auto child = testing::run_unprivileged(limits, [] {
    reset_fallback_notice_for_tests();
    const std::string within = describe_start(10);
    return within + "\n" + describe_start(11);
  });
  if (!child.ran && child.problem.rfind("setrlimit", 0) == 0) {
    GTEST_SKIP() << "cannot raise RLIMIT_RTPRIO to 10 here (no CAP_SYS_RESOURCE): "
                 << child.problem;
  }
  ASSERT_TRUE(child.ran) << child.problem;
  const std::string within = child.output.substr(0, child.output.find('\n'));
  const std::string above = child.output.substr(child.output.find('\n') + 1);
  EXPECT_EQ(within.rfind("SCHED_FIFO 10 fell_back=false", 0), 0u) << within;
  EXPECT_EQ(above.rfind("SCHED_OTHER 0 fell_back=true first=true", 0), 0u) << above;
  EXPECT_NE(above.find("RLIMIT_RTPRIO 10"), std::string::npos) << above;
}

}  // namespace
}  // namespace rtplc::kernel_rt
