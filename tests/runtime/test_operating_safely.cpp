// Operating the runtime safely on a shared box: its image is owner-only, tools
// refuse an image or socket another user owns, a planted image neither blocks the
// runtime nor reaches the monitor, "already running" is a lock and not a pid in
// shared memory, a socket folder another user could enter is refused, and the
// control socket keeps answering `status` and `stop` with 100 idle clients.
// The second user is uid 65534 (nobody), used by forking and dropping root.
#include <fcntl.h>
#include <gtest/gtest.h>

#include <fstream>
#include <sys/mman.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <thread>
#include <vector>

#include "sched/control.h"
#include "tests/kernel_rt/privilege_drop.h"
#include "tests/support/runtime_fixture.h"

namespace rtplc::sched {
namespace {

using rtplc::testing::RuntimeFixture;
namespace kt = rtplc::kernel_rt::testing;

const char* kTask = "tasks:\n  - {name: t, program: p.fbd, period: 10ms}\n";
const char* kProgram = "%%\nF1 = asp(d0, c0, 50, \"SP\")\ndao(F1, p0, d0, c0, \"OUT\")\nEND\n";

TEST(OperatingSafely, the_image_is_readable_by_its_owner_only) {
  RuntimeFixture fx;
  fx.write("p.fbd", kProgram);
  auto rt = fx.start(kTask);
  ASSERT_NE(rt, nullptr);
  struct stat st {};
  ASSERT_EQ(stat(("/dev/shm" + rt->image().object_name()).c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u);
  EXPECT_EQ(st.st_uid, geteuid());
  rt->stop();
}

TEST(OperatingSafely, a_planted_image_neither_blocks_the_runtime_nor_reaches_a_tool) {
  if (!kt::can_drop_privileges()) GTEST_SKIP() << "needs root to act as a second user";
  RuntimeFixture fx;
  fx.write("p.fbd", kProgram);
  const std::string name = fx.unique_name();
  const std::string obj = io::ProcessImage::shm_name(name);
  // Another user plants an object under the runtime's name, claiming pid 1.
  kt::ChildOutcome planted = kt::run_unprivileged({}, [&] {
    const int fd = shm_open(obj.c_str(), O_RDWR | O_CREAT | O_EXCL, 0644);
    if (fd < 0) return std::string("shm_open: ") + std::strerror(errno);
    if (ftruncate(fd, 1 << 16) != 0) return std::string("ftruncate failed");
    void* p = mmap(nullptr, 1 << 16, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
    auto* h = static_cast<io::ImageHeader*>(p);
    std::memcpy(h->magic, io::kProcessImageMagic, 8);
    h->version = io::kProcessImageVersion;
    h->pid = 1;
    munmap(p, 1 << 16);
    close(fd);
    return std::string("planted");
  });
  ASSERT_TRUE(planted.ran) << planted.problem;
  ASSERT_EQ(planted.output, "planted");
  // A tool refuses it: it belongs to neither root nor the caller.
  auto seen = io::ProcessImage::attach(name);
  ASSERT_FALSE(seen.ok());
  EXPECT_NE(seen.error().find("belongs to uid 65534"), std::string::npos) << seen.error();
  // The runtime starts anyway (no live runtime holds its lock) and replaces it.
  sched::RuntimeOptions opt;
  opt.name_override = name;
  opt.socket_override = fx.dir() + "/planted.sock";
  opt.retain_override = fx.dir() + "/planted.retain";
  std::string errors;
  auto rt = fx.load(kTask, &errors, opt);
  ASSERT_NE(rt, nullptr) << errors;
  ASSERT_TRUE(rt->start().ok());
  auto real = io::ProcessImage::attach(name);
  ASSERT_TRUE(real.ok()) << real.error();
  EXPECT_EQ(real->header().pid, getpid());
  rt->stop();
}

TEST(OperatingSafely, a_second_runtime_of_the_same_name_is_refused_by_its_lock) {
  RuntimeFixture fx;
  fx.write("p.fbd", kProgram);
  sched::RuntimeOptions opt;
  opt.name_override = fx.unique_name();
  opt.socket_override = fx.dir() + "/same.sock";
  auto a = fx.load(kTask, nullptr, opt);
  ASSERT_NE(a, nullptr);
  std::string errors;
  auto b = fx.load(kTask, &errors, opt);
  EXPECT_EQ(b, nullptr);
  EXPECT_NE(errors.find("already running (pid " + std::to_string(getpid())), std::string::npos) << errors;
  a.reset();  // its lock goes with it
  auto c = fx.load(kTask, &errors, opt);
  EXPECT_NE(c, nullptr) << errors;
}

TEST(OperatingSafely, a_retain_folder_other_users_may_write_to_is_refused_before_anything_is_read) {
  RuntimeFixture fx;
  fx.write("p.fbd", kProgram);
  const std::string shared = fx.dir() + "/shared";
  ASSERT_EQ(mkdir(shared.c_str(), 0700), 0);
  ASSERT_EQ(chmod(shared.c_str(), 01777), 0);
  // What another user could have planted there: a retained set-point.
  {
    std::ofstream(shared + "/r.retain") << "Setpoint 99\n";
  }
  sched::RuntimeOptions opt;
  opt.retain_override = shared + "/r.retain";
  std::string errors;
  EXPECT_EQ(fx.load(kTask, &errors, opt), nullptr);
  EXPECT_NE(errors.find("retain folder: refusing " + shared + ": other users may write to it"), std::string::npos)
      << errors;
}

TEST(OperatingSafely, a_socket_folder_another_user_could_enter_is_refused) {
  RuntimeFixture fx;
  fx.write("p.fbd", kProgram);
  const std::string open_dir = fx.dir() + "/open";
  ASSERT_EQ(mkdir(open_dir.c_str(), 0700), 0);
  ASSERT_EQ(chmod(open_dir.c_str(), 0750), 0);
  sched::RuntimeOptions opt;
  opt.socket_override = open_dir + "/r.sock";
  std::string errors;
  EXPECT_EQ(fx.load(kTask, &errors, opt), nullptr);
  EXPECT_NE(errors.find("lets other users in"), std::string::npos) << errors;
  // A shared folder such as /tmp (1777) is refused too, and the advice is a
  // folder of the runtime's own: never to change a folder others rely on.
  ASSERT_EQ(chmod(open_dir.c_str(), 01777), 0);
  EXPECT_EQ(fx.load(kTask, &errors, opt), nullptr);
  EXPECT_NE(errors.find("is a shared folder (mode 1777)"), std::string::npos) << errors;
  EXPECT_EQ(errors.find("chmod"), std::string::npos) << errors;
  if (kt::can_drop_privileges()) {
    const std::string theirs = fx.dir() + "/theirs";
    ASSERT_EQ(mkdir(theirs.c_str(), 0700), 0);
    ASSERT_EQ(chown(theirs.c_str(), 65534, 65534), 0);
    opt.socket_override = theirs + "/r.sock";
    EXPECT_EQ(fx.load(kTask, &errors, opt), nullptr);
    EXPECT_NE(errors.find("belongs to uid 65534"), std::string::npos) << errors;
  }
}

int connect_idle(const std::string& path) {
  const int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::memcpy(addr.sun_path, path.c_str(), path.size());
  if (connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    close(fd);
    return -1;
  }
  return fd;
}

TEST(OperatingSafely, status_and_stop_answer_beside_a_hundred_idle_clients) {
  RuntimeFixture fx;
  fx.write("p.fbd", kProgram);
  auto rt = fx.start(kTask);
  ASSERT_NE(rt, nullptr);
  ControlServer server(*rt, [](bool, const std::string&) {});
  ASSERT_TRUE(server.start(rt->socket_path()).ok());
  std::vector<int> idle;
  for (int i = 0; i < 100; ++i) {
    const int fd = connect_idle(rt->socket_path());
    ASSERT_GE(fd, 0) << "connection " << i;
    idle.push_back(fd);
  }
  // Half of them have sent half a line and gone quiet.
  for (size_t i = 0; i < idle.size(); i += 2) ASSERT_EQ(send(idle[i], "sta", 3, MSG_NOSIGNAL), 3);
  auto status = control_request(rt->socket_path(), "status", "", 3000);
  ASSERT_TRUE(status.ok()) << status.error();
  EXPECT_NE(status->find("task t"), std::string::npos);
  auto stop = control_request(rt->socket_path(), "stop", "", 3000);
  ASSERT_TRUE(stop.ok()) << stop.error();
  EXPECT_TRUE(server.stop_requested());
  for (int fd : idle) close(fd);
  server.stop();
  rt->stop();
}

}  // namespace
}  // namespace rtplc::sched
