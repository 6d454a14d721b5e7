// The one bounded file reader and the atomic writer against what a user or
// another local user can put where a file is expected: FIFOs, devices,
// folders, files over the limit, links planted in the runtime's folders.
#include "common/files.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <string>

#include "tests/support/scratch.h"

namespace rtplc {
namespace {



TEST(ReadFileBounded, reads_a_whole_regular_file) {
  test::Scratch s("rtplc-files");
  const std::string text(100000, 'x');
  Result<std::string> r = read_file_bounded(s.write("a.fbd", text), 1 << 20);
  ASSERT_TRUE(r) << r.error();
  EXPECT_EQ(*r, text);
}

TEST(ReadFileBounded, refuses_a_file_over_the_limit_naming_it) {
  test::Scratch s("rtplc-files");
  const std::string p = s.write("big.fbd", std::string(5000, 'x'));
  Result<std::string> r = read_file_bounded(p, 4096);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().rfind(p + ": is 5000 bytes; at most 4 KiB", 0), 0u) << r.error();
  EXPECT_TRUE(read_file_bounded(p, 5000)) << "exactly the limit is allowed";
}

TEST(ReadFileBounded, refuses_devices_folders_and_missing_files_with_the_reason) {
  test::Scratch s("rtplc-files");
  Result<std::string> zero = read_file_bounded("/dev/zero", 1 << 20);
  ASSERT_FALSE(zero);
  EXPECT_NE(zero.error().find("/dev/zero: is a character device"), std::string::npos) << zero.error();
  Result<std::string> dir = read_file_bounded("/tmp", 1 << 20);
  ASSERT_FALSE(dir);
  EXPECT_NE(dir.error().find("is a folder"), std::string::npos) << dir.error();
  Result<std::string> gone = read_file_bounded(s.path("gone.fbd"), 1 << 20);
  ASSERT_FALSE(gone);
  EXPECT_TRUE(is_missing_file_error(gone.error())) << gone.error();
  EXPECT_FALSE(is_missing_file_error(dir.error()));
  EXPECT_EQ(file_error_reason(s.path("gone.fbd"), gone.error()), "no such file");
}

TEST(ReadFileBounded, refuses_a_fifo_without_waiting_for_a_writer) {
  test::Scratch s("rtplc-files");
  const std::string fifo = s.path("prog.fbd");
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  // Without O_NONBLOCK this open would wait for a writer forever.
  Result<std::string> r = read_file_bounded(fifo, 1 << 20);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("is a FIFO"), std::string::npos) << r.error();
}

TEST(ReadFileBounded, follows_a_link_only_when_told_to) {
  test::Scratch s("rtplc-files");
  const std::string target = s.write("secret", "root-only text\n");
  const std::string link = s.path("x.retain");
  ASSERT_EQ(symlink(target.c_str(), link.c_str()), 0);
  EXPECT_TRUE(read_file_bounded(link, 1 << 20, FollowLinks::kYes));
  Result<std::string> r = read_file_bounded(link, 1 << 20, FollowLinks::kNo);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("is a symbolic link"), std::string::npos) << r.error();
}

TEST(WriteFileAtomically, never_writes_through_a_link_planted_at_its_temporary_name) {
  test::Scratch s("rtplc-files");
  const std::string victim = s.write("victim", "keep me\n");
  const std::string out = s.path("state.retain");
  ASSERT_EQ(symlink(victim.c_str(), (out + ".tmp").c_str()), 0);
  Result<void> w = write_file_atomically(out, "Setpoint 42\n", 0600);
  EXPECT_FALSE(w);
  EXPECT_EQ(test::slurp(victim), "keep me\n") << "the write went through the planted link";
  struct stat st{};
  EXPECT_NE(stat(out.c_str(), &st), 0) << "a refused write created the file anyway";
}

TEST(WriteFileAtomically, replaces_a_stale_temporary_file_left_by_a_crash) {
  test::Scratch s("rtplc-files");
  const std::string out = s.path("state.retain");
  s.write("state.retain.tmp", "half a file from before the crash");
  ASSERT_TRUE(write_file_atomically(out, "Setpoint 42\n", 0600));
  EXPECT_EQ(test::slurp(out), "Setpoint 42\n");
  struct stat st{};
  EXPECT_NE(stat((out + ".tmp").c_str(), &st), 0);
}

TEST(WriteFileAtomically, leaves_no_temporary_file_when_the_target_is_a_folder) {
  test::Scratch s("rtplc-files");
  const std::string dir = s.path("out.csv");
  ASSERT_EQ(mkdir(dir.c_str(), 0700), 0);
  EXPECT_FALSE(write_file_atomically(dir, "t,x\n", 0644));
  struct stat st{};
  EXPECT_NE(stat((dir + ".tmp").c_str(), &st), 0);
}

TEST(StateFolder, is_created_private_and_refused_when_a_link_or_writable_by_others) {
  test::Scratch s("rtplc-files");
  const std::string made = s.path("state/rtplc");
  ASSERT_TRUE(ensure_state_folder(made, true));
  struct stat st{};
  ASSERT_EQ(stat(made.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0700u);
  // `check` creates nothing.
  EXPECT_TRUE(ensure_state_folder(s.path("not-yet"), false));
  EXPECT_NE(stat(s.path("not-yet").c_str(), &st), 0);
  // A link planted where the state folder is expected.
  ASSERT_EQ(symlink(made.c_str(), s.path("link").c_str()), 0);
  Result<void> r = ensure_state_folder(s.path("link"), true);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("symbolic link"), std::string::npos) << r.error();
  // A folder others may write to (a shared /tmp is 1777).
  const std::string shared = s.path("shared");
  ASSERT_EQ(mkdir(shared.c_str(), 0700), 0);
  ASSERT_EQ(chmod(shared.c_str(), 01777), 0);
  r = ensure_state_folder(shared, true);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("other users may write to it (mode 1777)"), std::string::npos) << r.error();
  // Group-readable is the operator's choice (deploy may share it with a group).
  ASSERT_EQ(chmod(shared.c_str(), 0750), 0);
  EXPECT_TRUE(ensure_state_folder(shared, true));
  if (geteuid() == 0) {
    ASSERT_EQ(chown(shared.c_str(), 65534, 65534), 0);
    r = ensure_state_folder(shared, true);
    ASSERT_FALSE(r);
    EXPECT_NE(r.error().find("belongs to uid 65534"), std::string::npos) << r.error();
  }
}

TEST(SameFile, is_true_for_one_file_by_two_names_only) {
  test::Scratch s("rtplc-files");
  const std::string a = s.write("a.fbd", "x");
  const std::string b = s.write("b.fbd", "x");
  ASSERT_EQ(symlink(a.c_str(), s.path("l.fbd").c_str()), 0);
  EXPECT_TRUE(same_file(a, s.path("l.fbd")));
  EXPECT_TRUE(same_file(a, s.path("./a.fbd")));
  EXPECT_FALSE(same_file(a, b));
  EXPECT_FALSE(same_file(a, s.path("none")));
}

}  // namespace
}  // namespace rtplc
