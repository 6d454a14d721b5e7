// The control socket server and client (see control.h).
#include "sched/control.h"

#include <fcntl.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <time.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <sstream>

#include "common/files.h"
#include "kernel_rt/clock.h"
#include "kernel_rt/rt_thread.h"
#include "sched/runtime.h"

namespace rtplc::sched {
namespace {

constexpr size_t kMaxLine = 4096;
constexpr size_t kMaxClients = 256;
constexpr int kRequestTimeoutMs = 10000;
constexpr size_t kMaxSource = 64u << 20;  // the compiler refuses more anyway

bool send_all(int fd, const std::string& s) {
  size_t done = 0;
  while (done < s.size()) {
    const ssize_t n = send(fd, s.data() + done, s.size() - done, MSG_NOSIGNAL);
    if (n < 0) {
      if (errno == EINTR) continue;
      return false;
    }
    done += static_cast<size_t>(n);
  }
  return true;
}

bool read_line(int fd, std::string& line, int timeout_ms) {
  line.clear();
  const int64_t deadline = kernel_rt::monotonic_now_ns() + int64_t{timeout_ms} * 1000000;
  for (;;) {
    if (line.size() > kMaxLine) return false;
    const int64_t left_ms = (deadline - kernel_rt::monotonic_now_ns()) / 1000000;
    if (left_ms <= 0) return false;
    pollfd p{fd, POLLIN, 0};
    if (poll(&p, 1, static_cast<int>(left_ms)) <= 0) return false;
    char c;
    const ssize_t n = recv(fd, &c, 1, 0);
    if (n <= 0) return false;
    if (c == '\n') return true;
    line += c;
  }
}

std::string frame(bool ok, const std::string& body) {
  std::string out = ok ? "OK\n" : "ERROR\n";
  std::istringstream in(body);
  std::string l;
  while (std::getline(in, l)) {
    if (!l.empty() && l[0] == '.') out += '.';
    out += l + "\n";
  }
  return out + ".\n";
}


std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> v;
  std::istringstream in(s);
  std::string w;
  while (in >> w) v.push_back(w);
  return v;
}

}  // namespace

ControlServer::~ControlServer() { stop(); }

Result<void> ControlServer::start(const std::string& path) {
  path_ = path;
  // Beside the state file in the runtime's checked state folder: NAME.audit.
  std::string audit = rt_.state_path();
  if (audit.size() > 6 && audit.compare(audit.size() - 6, 6, ".state") == 0) audit.resize(audit.size() - 6);
  audit_ = AuditLog(audit + ".audit");
  sockaddr_un addr{};
  if (path.size() >= sizeof addr.sun_path) return make_error("control socket path too long: " + path);
  // Create the folder chain (e.g. /run/rtplc); the last folder is private.
  if (auto r = ensure_private_folder(folder_of(path)); !r) return r;
  // A socket left by a dead runtime: connecting fails, so remove it. A live one
  // answers: then another runtime owns the name.
  if (access(path.c_str(), F_OK) == 0) {
    if (control_request(path, "ping", "", 500).ok()) {
      return make_error("a runtime already listens on " + path);
    }
    unlink(path.c_str());
  }
  listen_fd_ = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (listen_fd_ < 0) return make_error(std::string("socket: ") + std::strerror(errno));
  addr.sun_family = AF_UNIX;
  std::memcpy(addr.sun_path, path.c_str(), path.size());
  const mode_t old = umask(0177);  // the socket is born 0600: no window where others can connect
  const int b = bind(listen_fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr);
  umask(old);
  if (b != 0 || listen(listen_fd_, 8) != 0) {
    const int e = errno;
    close(listen_fd_);
    listen_fd_ = -1;
    return make_error("cannot listen on " + path + ": " + std::strerror(e));
  }
  chmod(path.c_str(), 0600);
  fcntl(listen_fd_, F_SETFL, fcntl(listen_fd_, F_GETFL) | O_NONBLOCK);
  kernel_rt::ThreadSpec spec;
  spec.name = "rtplc:control";
  auto t = kernel_rt::start_thread(spec, [this] { run(); });
  if (!t) {
    close(listen_fd_);
    listen_fd_ = -1;
    unlink(path.c_str());
    return make_error("control thread: " + t.error());
  }
  thread_ = std::move(t).value();
  return {};
}

void ControlServer::stop() {
  quit_.store(true, std::memory_order_release);
  if (thread_.joinable()) thread_.join();
  if (listen_fd_ >= 0) {
    close(listen_fd_);
    listen_fd_ = -1;
    unlink(path_.c_str());
  }
}

// The event loop: any number of clients at once, each read and written without
// blocking, so an idle or slow client never delays another's `status` or
// `stop`. A request must arrive whole within kRequestTimeoutMs; the loop holds at
// most kMaxClients connections and answers any beyond that at once with an error.
void ControlServer::run() {
  struct Client {
    int fd = -1;
    std::string in;
    std::string out;
    size_t sent = 0;
    int64_t deadline = 0;
    bool answered = false;
    uint32_t uid = 0;  // the peer's, from SO_PEERCRED
  };
  std::vector<Client> clients;
  std::vector<pollfd> fds;
  auto answer = [](Client& c, const std::string& framed) {
    c.out = framed;
    c.sent = 0;
    c.answered = true;
  };
  while (!quit_.load(std::memory_order_acquire)) {
    fds.clear();
    fds.push_back({listen_fd_, POLLIN, 0});
    for (const Client& c : clients) fds.push_back({c.fd, static_cast<short>(c.answered ? POLLOUT : POLLIN), 0});
    const int n = poll(fds.data(), static_cast<nfds_t>(fds.size()), 100);
    rt_.reap();
    rt_.tick(log_);
    watch_tasks();
    const int64_t now = kernel_rt::monotonic_now_ns();
    if (n > 0 && (fds[0].revents & POLLIN)) {
      for (;;) {
        const int fd = accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC | SOCK_NONBLOCK);
        if (fd < 0) break;
        if (clients.size() >= kMaxClients) {
          const std::string busy = frame(false, "too many clients are connected to this runtime; try again");
          [[maybe_unused]] const ssize_t w = send(fd, busy.data(), busy.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
          close(fd);
          continue;
        }
        // Who is asking: the kernel's word for it, fixed at connect time.
        ucred cred{};
        socklen_t cred_len = sizeof cred;
        if (getsockopt(fd, SOL_SOCKET, SO_PEERCRED, &cred, &cred_len) != 0) {
          close(fd);
          continue;
        }
        Client c;
        c.fd = fd;
        c.uid = cred.uid;
        c.deadline = now + int64_t{kRequestTimeoutMs} * 1000000;
        clients.push_back(std::move(c));
      }
    }
    for (size_t i = 0; i < clients.size(); ++i) {
      Client& c = clients[i];
      const short rev = i + 1 < fds.size() && fds[i + 1].fd == c.fd ? fds[i + 1].revents : 0;
      bool drop = false;
      if (!c.answered && (rev & (POLLIN | POLLHUP | POLLERR))) {
        char buf[16384];
        const ssize_t got = recv(c.fd, buf, sizeof buf, 0);
        if (got <= 0) {
          drop = got == 0 || (errno != EAGAIN && errno != EINTR);
        } else {
          c.in.append(buf, static_cast<size_t>(got));
          std::string response;
          switch (parse_request(c.in, response, c.uid)) {
            case RequestState::kIncomplete: break;
            case RequestState::kComplete:
            case RequestState::kBad: answer(c, response); break;
          }
        }
      }
      if (!c.answered && now > c.deadline) answer(c, frame(false, "the request did not arrive whole in time"));
      if (c.answered && c.sent < c.out.size()) {
        const ssize_t w = send(c.fd, c.out.data() + c.sent, c.out.size() - c.sent, MSG_NOSIGNAL | MSG_DONTWAIT);
        if (w > 0) c.sent += static_cast<size_t>(w);
        else if (errno != EAGAIN && errno != EINTR) drop = true;
      }
      if (c.answered && c.sent >= c.out.size()) drop = true;
      if (c.answered && now > c.deadline + int64_t{kRequestTimeoutMs} * 1000000) drop = true;  // never reads
      if (drop) {
        close(c.fd);
        clients[i] = std::move(clients.back());
        clients.pop_back();
        --i;
      }
    }
  }
  for (Client& c : clients) close(c.fd);
}

ControlServer::RequestState ControlServer::parse_request(const std::string& in, std::string& response,
                                                        uint32_t uid) {
  const size_t nl = in.find('\n');
  if (nl == std::string::npos) {
    if (in.size() > kMaxLine) {
      response = frame(false, "malformed request: expected one line");
      return RequestState::kBad;
    }
    return RequestState::kIncomplete;
  }
  const std::vector<std::string> w = split(in.substr(0, nl));
  if (w.empty()) {
    response = frame(false, "empty request");
    return RequestState::kBad;
  }
  std::string body;
  if (w[0] == "swap" && w.size() >= 4) {
    char* end = nullptr;
    const unsigned long long want = std::strtoull(w[3].c_str(), &end, 10);
    if (*end != '\0' || want > kMaxSource) {
      response = frame(false, "bad source size");
      return RequestState::kBad;
    }
    if (in.size() - nl - 1 < want) return RequestState::kIncomplete;
    body = in.substr(nl + 1, want);
  }
  response = execute(w, body, uid);
  return RequestState::kComplete;
}

void ControlServer::watch_tasks() {
  io::ProcessImage& img = rt_.image();
  last_state_.resize(rt_.task_count(), 0);
  for (size_t t = 0; t < rt_.task_count(); ++t) {
    const auto s = img.task_info(static_cast<uint32_t>(t)).state.load(std::memory_order_relaxed);
    if (s == last_state_[t]) continue;
    last_state_[t] = s;
    if (s == static_cast<uint8_t>(io::TaskState::kStoppedWatchdog)) {
      const Task& task = rt_.task(t);
      log_(true, "WATCHDOG: task " + task.params().name + " STOPPED after " +
                     std::to_string(task.params().watchdog ? task.params().watchdog : 1) +
                     " consecutive overruns; its outputs are at their safe values. Swap in "
                     "fixed code (rtplc swap " + task.params().name + " FILE) to restart it.");
    }
  }
}

// "drop=A,B" -> {"A", "B"}: the outputs a swap may leave out (--drop-output).
static std::vector<std::string> drop_list(const std::string& word) {
  std::vector<std::string> out;
  std::string cur;
  for (char c : word.substr(5)) {
    if (c == ',') {
      if (!cur.empty()) out.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  if (!cur.empty()) out.push_back(cur);
  return out;
}

// Answer lines joined for one log line: "a; b", no trailing separator.
static std::string one_line(const std::string& text) {
  std::string out;
  size_t from = 0;
  while (from < text.size()) {
    size_t nl = text.find('\n', from);
    if (nl == std::string::npos) nl = text.size();
    if (nl > from) out += (out.empty() ? "" : "; ") + text.substr(from, nl - from);
    from = nl + 1;
  }
  return out;
}

// A number as the operator typed it; "nan" and "inf" parse, so the verb can
// refuse them with its own reason (and the range of a set-point).
static bool parse_number(const std::string& word, double& v) {
  char* end = nullptr;
  v = std::strtod(word.c_str(), &end);
  return end != word.c_str() && *end == '\0';
}

std::string ControlServer::execute(const std::vector<std::string>& w, const std::string& source, uint32_t uid) {
  const std::string& verb = w[0];
  if (verb == "audit" && w.size() <= 2) {
    size_t n = 50;
    if (w.size() == 2) {
      char* end = nullptr;
      const unsigned long v = std::strtoul(w[1].c_str(), &end, 10);
      if (*end != '\0' || v == 0 || v > 100000) return frame(false, "audit takes a number of lines, 1 to 100000");
      n = v;
    }
    auto lines = audit_.tail(n);
    if (!lines) return frame(false, lines.error());
    std::string body;
    for (const std::string& l : *lines) body += l + "\n";
    return frame(true, body.empty() ? "no action recorded yet in " + audit_.path() + "\n" : body);
  }
  std::string answer = run_verb(w, source, uid);
  static const char* const kWrites[] = {"set", "force", "unforce", "unforce_all", "swap", "rollback", "trace", "stop"};
  for (const char* write : kWrites) {
    if (verb != write) continue;
    // One line: when, who, what was asked (a swap's source by its size), what came of it.
    std::string asked;
    for (size_t i = 0; i < w.size(); ++i) asked += (i ? " " : "") + w[i];
    const bool ok = answer.rfind("OK\n", 0) == 0;
    std::string body = answer.substr(answer.find('\n') + 1);
    if (body.size() >= 2 && body.compare(body.size() - 2, 2, ".\n") == 0) body.resize(body.size() - 2);  // the frame's end
    std::string said = one_line(body);
    if (said.size() > 400) said = said.substr(0, 400) + "...";
    auto r = audit_.append(format_utc(kernel_rt::realtime_now_ns()) + " uid " + std::to_string(uid) + " " + asked +
                           (ok ? ": " : ": refused: ") + said);
    if (!r) log_(true, r.error());
    break;
  }
  return answer;
}

std::string ControlServer::run_verb(const std::vector<std::string>& w, const std::string& source, uint32_t uid) {
  const std::string& verb = w[0];
  Result<std::string> res = make_error("unknown request '" + verb +
                                       "' (ping, status, set, swap, rollback, force, unforce, unforce_all, "
                                       "trace, trace-keep, trace-end, audit, stop)");
  const std::string who = " by uid " + std::to_string(uid) + " at " + format_utc(kernel_rt::realtime_now_ns());
  if (verb == "ping" && w.size() == 1) {
    res = std::string("pong ") + rt_.name();
  } else if (verb == "status" && w.size() == 1) {
    res = rt_.status();
  } else if (verb == "status" && w.size() == 2 && w[1] == "json") {
    res = rt_.status_json();
  } else if (verb == "set" && w.size() == 3) {
    double v = 0;
    if (!parse_number(w[2], v)) {
      res = make_error("'" + w[2] + "' is not a number");
    } else {
      res = rt_.set_value(w[1], v);
      if (res) log_(false, "set " + *res + who);
    }
  } else if (verb == "force" && w.size() == 3) {
    double v = 0;
    if (!parse_number(w[2], v)) {
      res = make_error("not forced: '" + w[2] + "' is not a number");
    } else {
      res = rt_.force(w[1], v, uid);
      log_(true, "FORCE " + w[1] + " = " + w[2] + who + (res ? ": " + *res : ": refused: " + res.error()));
    }
  } else if (verb == "unforce" && w.size() == 2) {
    res = rt_.unforce(w[1]);
    if (res) log_(true, "UNFORCE " + w[1] + who + ": " + *res);
  } else if (verb == "unforce_all" && w.size() == 1) {
    res = rt_.unforce_all();
    if (res) {
      log_(true, "UNFORCE --all" + who + ": " + one_line(*res));
    }
  } else if (verb == "swap" && (w.size() == 4 || (w.size() == 5 && w[4].rfind("drop=", 0) == 0))) {
    res = rt_.swap(w[1], source, w[2], w.size() == 5 ? drop_list(w[4]) : std::vector<std::string>{});
    // One log line per swap: its first two answer lines (compiled, installed).
    if (res) {
      std::string said = one_line(res->substr(0, res->find('\n', res->find('\n') + 1)));
      log_(false, "swap of " + w[1] + who + ": " + said);
    } else {
      log_(true, "swap of " + w[1] + who + " refused: " + res.error().substr(0, res.error().find('\n')));
    }
  } else if (verb == "rollback" && (w.size() == 2 || (w.size() == 3 && w[2].rfind("drop=", 0) == 0))) {
    res = rt_.rollback(w[1], w.size() == 3 ? drop_list(w[2]) : std::vector<std::string>{});
    if (res) log_(false, "rollback of " + w[1] + who + ": " + res->substr(0, res->find('\n')));
  } else if (verb == "trace" && w.size() >= 2) {
    res = rt_.trace_start(std::vector<std::string>(w.begin() + 1, w.end()));
    if (res) {
      std::string labels;
      for (size_t i = 1; i < w.size(); ++i) labels += (i > 1 ? ", " : "") + w[i];
      log_(false, res->substr(0, res->find('\n')) + " started: " + labels);
    }
  } else if (verb == "trace-keep" && w.size() == 2) {
    res = rt_.trace_keep(w[1]);
  } else if (verb == "trace-end" && w.size() == 2) {
    res = rt_.trace_end(w[1]);
    if (res) log_(false, "trace " + w[1] + " ended by its reader");
  } else if (verb == "stop" && w.size() == 1) {
    log_(false, "stop requested" + who);
    stop_requested_.store(true, std::memory_order_release);
    res = std::string("stopping runtime ") + rt_.name();
  } else if (verb == "set" || verb == "swap" || verb == "rollback" || verb == "force" || verb == "unforce" ||
             verb == "unforce_all" || verb == "trace" || verb == "trace-keep" || verb == "trace-end") {
    res = make_error("wrong number of arguments for '" + verb + "'");
  }
  return res ? frame(true, *res) : frame(false, res.error());
}

std::string control_socket_of(const std::string& name, const std::string& socket_override) {
  if (!socket_override.empty()) return socket_override;
  if (auto img = io::ProcessImage::attach(name); img.ok()) {
    const io::ImageHeader& h = img->header();
    const size_t n = strnlen(h.socket_path, sizeof h.socket_path);
    if (n > 0 && n < sizeof h.socket_path) return std::string(h.socket_path, n);
  }
  return default_socket_path(name);
}

Result<std::string> control_request(const std::string& socket_path, const std::string& line,
                                    const std::string& payload, int timeout_ms) {
  sockaddr_un addr{};
  if (socket_path.size() >= sizeof addr.sun_path) return make_error("socket path too long");
  // Talk only to a socket root or we own: a socket another user put in our way
  // would receive our commands (and could answer anything).
  struct stat st {};
  if (lstat(socket_path.c_str(), &st) == 0 && st.st_uid != 0 && st.st_uid != geteuid()) {
    return make_error("refusing the control socket " + socket_path + ": it belongs to uid " +
                      std::to_string(st.st_uid) + ", neither root nor you");
  }
  const int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return make_error(std::string("socket: ") + std::strerror(errno));
  addr.sun_family = AF_UNIX;
  std::memcpy(addr.sun_path, socket_path.c_str(), socket_path.size());
  if (connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    const int e = errno;
    close(fd);
    return make_error("cannot reach the runtime at " + socket_path + " (" + std::strerror(e) +
                      "); is `rtplc run` running, and are you allowed to use its socket?");
  }
  bool ok = send_all(fd, line + "\n") && send_all(fd, payload);
  std::string status, body, l;
  ok = ok && read_line(fd, status, timeout_ms);
  // An answer counts only with its terminating "." line: one cut off (the
  // runtime died or was stopped mid-answer) is not taken for a whole one.
  bool whole = false;
  while (ok && read_line(fd, l, timeout_ms)) {
    if (l == ".") {
      whole = true;
      break;
    }
    body += (l.size() > 1 && l[0] == '.' ? l.substr(1) : l) + "\n";
  }
  close(fd);
  if (!ok) return make_error("no answer from the runtime at " + socket_path);
  if (!whole) {
    return make_error("the runtime's answer at " + socket_path +
                      " was cut off before its end; what it did is unknown: check with `rtplc status`");
  }
  if (status == "OK") return body;
  return make_error(body.empty() ? "the runtime refused the request" : body);
}

}  // namespace rtplc::sched
