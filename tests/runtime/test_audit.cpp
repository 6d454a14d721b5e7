// The audit trail's file (sched/audit.h): lines in order, newlines inside a
// line flattened, bounded by rotation to NAME.audit.1, and never written
// through a link planted where the file should be.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <string>

#include "sched/audit.h"
#include "tests/support/scratch.h"

namespace rtplc::sched {
namespace {

using rtplc::test::Scratch;

TEST(AuditLog, keeps_lines_in_order_and_gives_the_last_n) {
  Scratch s;
  AuditLog a(s.path("rt.audit"));
  auto none = a.tail(10);
  ASSERT_TRUE(none.ok()) << none.error();
  EXPECT_TRUE(none->empty());
  ASSERT_TRUE(a.append("one").ok());
  ASSERT_TRUE(a.append("two\nhalves").ok());
  ASSERT_TRUE(a.append("three").ok());
  auto last = a.tail(2);
  ASSERT_TRUE(last.ok());
  ASSERT_EQ(last->size(), 2u);
  EXPECT_EQ((*last)[0], "two halves");
  EXPECT_EQ((*last)[1], "three");
  struct stat st {};
  ASSERT_EQ(stat(a.path().c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u);
}

TEST(AuditLog, stays_bounded_by_rotating_and_still_reads_across_both_files) {
  Scratch s;
  AuditLog a(s.path("rt.audit"));
  const std::string line(1000, 'x');
  const int n = static_cast<int>(3 * AuditLog::kMaxBytes / 1001);
  for (int i = 0; i < n; ++i) ASSERT_TRUE(a.append(line + std::to_string(i)).ok());
  struct stat cur {}, old {};
  ASSERT_EQ(stat(a.path().c_str(), &cur), 0);
  ASSERT_EQ(stat((a.path() + ".1").c_str(), &old), 0);
  EXPECT_LE(static_cast<size_t>(cur.st_size), AuditLog::kMaxBytes);
  EXPECT_LE(static_cast<size_t>(old.st_size), AuditLog::kMaxBytes);
  // At least a whole file's worth is kept: the rotated one is full.
  const size_t whole = AuditLog::kMaxBytes / (line.size() + 4);
  auto last = a.tail(whole);
  ASSERT_TRUE(last.ok());
  ASSERT_EQ(last->size(), whole) << "the last lines span the rotated file too";
  EXPECT_EQ(last->back(), line + std::to_string(n - 1));
  EXPECT_EQ(last->front(), line + std::to_string(n - static_cast<int>(whole)));
}

TEST(AuditLog, does_not_write_through_a_link) {
  Scratch s;
  const std::string target = s.write("elsewhere", "");
  ASSERT_EQ(symlink(target.c_str(), s.path("rt.audit").c_str()), 0);
  AuditLog a(s.path("rt.audit"));
  auto r = a.append("x");
  EXPECT_FALSE(r.ok());
  struct stat st {};
  ASSERT_EQ(stat(target.c_str(), &st), 0);
  EXPECT_EQ(st.st_size, 0) << "nothing reached the link's target";
}

}  // namespace
}  // namespace rtplc::sched
