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

constexpr size_t kMaxHeader = 64;  // "RTPLC-API 1 JSON_BYTES PAYLOAD_BYTES"
constexpr size_t kMaxJson = 1u << 20;          // a request's JSON
constexpr size_t kMaxAnswerJson = 64u << 20;   // an answer's (a long audit tail, many channels)
constexpr size_t kMaxClients = 256;
constexpr int kRequestTimeoutMs = 10000;
constexpr size_t kMaxSource = 64u << 20;  // the compiler refuses more anyway
constexpr const char* kMagic = "RTPLC-API";

using nlohmann::json;

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

std::string frame(const json& j, const std::string& payload = "") {
  // Invalid UTF-8 in a message (a label the caller typed) is replaced, never thrown.
  const std::string text = j.dump(-1, ' ', false, json::error_handler_t::replace);
  return std::string(kMagic) + " " + std::to_string(kApiVersion) + " " + std::to_string(text.size()) + " " +
         std::to_string(payload.size()) + "\n" + text + payload;
}

std::string error_frame(const std::string& op, const std::string& code, const std::string& message) {
  return frame(ApiAnswer::failure(code, message).to_json(op));
}

// A frame's header: "RTPLC-API VERSION JSON_BYTES PAYLOAD_BYTES".
struct Header {
  int version = 0;
  size_t json_bytes = 0;
  size_t payload_bytes = 0;
};

Result<Header> parse_header(const std::string& line) {
  std::istringstream in(line);
  std::string magic, version, jb, pb, extra;
  in >> magic >> version >> jb >> pb;
  if (magic != kMagic || (in >> extra)) {
    return make_error("this is an rtplc control socket: it takes frames \"RTPLC-API 1 JSON_BYTES "
                      "PAYLOAD_BYTES\\n\" then the JSON request (docs/api.md)");
  }
  auto number = [](const std::string& w, size_t& out) {
    if (w.empty() || w.size() > 12 || w.find_first_not_of("0123456789") != std::string::npos) return false;
    out = std::stoull(w);
    return true;
  };
  Header h;
  size_t v = 0;
  if (!number(version, v) || !number(jb, h.json_bytes) || !number(pb, h.payload_bytes)) {
    return make_error("malformed frame header '" + line.substr(0, 60) + "'");
  }
  h.version = static_cast<int>(v);
  return h;
}

}  // namespace


ControlServer::ControlServer(Runtime& rt, Log log) : rt_(rt), log_(std::move(log)), api_(rt.api()) {
  api_.set_log(log_);
  rt_.set_tick_log(log_, [this] { return quit_.load(std::memory_order_acquire); });
}

ControlServer::~ControlServer() {
  stop();
  api_.set_log(nullptr);
  rt_.set_tick_log(nullptr, nullptr);
}

Result<void> ControlServer::start(const std::string& path) {
  path_ = path;
  sockaddr_un addr{};
  if (path.size() >= sizeof addr.sun_path) return make_error("control socket path too long: " + path);
  // Create the folder chain (e.g. /run/rtplc); the last folder is private,
  // or, when the config grants roles to others, enterable by them (0711).
  const bool shared = !rt_.grants().empty();
  if (auto r = ensure_private_folder(folder_of(path), shared); !r) return r;
  if (shared) {
    // The grants help only if others can walk the path to the socket.
    for (std::string dir = folder_of(folder_of(path)); dir.size() > 1; dir = folder_of(dir)) {
      struct stat st {};
      if (stat(dir.c_str(), &st) == 0 && (st.st_mode & S_IXOTH) == 0) {
        log_(true, "runtime.operators grants roles, but " + dir +
                       " is closed to other users, so they cannot reach the socket " + path +
                       "; set runtime.socket to a path they can reach (e.g. /run/rtplc-" + rt_.name() + "/" +
                       rt_.name() + ".sock as root, or a folder of yours under /home)");
        break;
      }
      if (dir == folder_of(dir)) break;
    }
  }
  // A socket left by a dead runtime: connecting fails, so remove it. A live one
  // answers: then another runtime owns the name.
  if (access(path.c_str(), F_OK) == 0) {
    if (api_request(path, json{{"op", "ping"}}, "", 500).ok()) {
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
  chmod(path.c_str(), shared ? 0666 : 0600);  // shared: every request is authorised by its uid
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
    Caller caller;  // from SO_PEERCRED
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
          const std::string busy = error_frame("", "busy", "too many clients are connected to this runtime; try again");
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
        c.caller.uid = cred.uid;
        c.caller.who = OperatorApi::name_of_uid(cred.uid);
        c.caller.role = api_.role_of_uid(cred.uid, cred.gid);
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
          switch (parse_request(c.in, response, c.caller)) {
            case RequestState::kIncomplete: break;
            case RequestState::kComplete:
            case RequestState::kBad: answer(c, response); break;
          }
        }
      }
      if (!c.answered && now > c.deadline) answer(c, error_frame("", "bad_request", "the request did not arrive whole in time"));
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
                                                        const Caller& caller) {
  const size_t nl = in.find('\n');
  if (nl == std::string::npos) {
    if (in.size() > kMaxHeader) {
      // No header line within kMaxHeader bytes: a frame's too long, anything else no frame at all.
      response = error_frame("", "bad_request", in.rfind(kMagic, 0) == 0 ? "malformed frame header: too long"
                                                                         : parse_header("").error());
      return RequestState::kBad;
    }
    return RequestState::kIncomplete;
  }
  auto h = parse_header(in.substr(0, nl));
  if (!h) {
    response = error_frame("", "bad_request", h.error());
    return RequestState::kBad;
  }
  if (h->version != kApiVersion) {
    response = error_frame("", "version", "this runtime speaks operator API version " + std::to_string(kApiVersion) +
                                              ", the request is version " + std::to_string(h->version));
    return RequestState::kBad;
  }
  if (h->json_bytes > kMaxJson || h->payload_bytes > kMaxSource) {
    response = error_frame("", "bad_request", "request too large");
    return RequestState::kBad;
  }
  if (in.size() - nl - 1 < h->json_bytes + h->payload_bytes) return RequestState::kIncomplete;
  const json request = json::parse(in.substr(nl + 1, h->json_bytes), nullptr, false);
  if (request.is_discarded()) {
    response = error_frame("", "bad_request", "the request is not valid JSON");
    return RequestState::kBad;
  }
  const std::string op = request.is_object() && request.contains("op") && request["op"].is_string()
                             ? request["op"].get<std::string>()
                             : std::string();
  response = frame(api_.call(caller, request, in.substr(nl + 1 + h->json_bytes, h->payload_bytes)).to_json(op));
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

std::string control_socket_of(const std::string& name, const std::string& socket_override) {
  if (!socket_override.empty()) return socket_override;
  if (auto img = io::ProcessImage::attach(name); img.ok()) {
    const io::ImageHeader& h = img->header();
    const size_t n = strnlen(h.socket_path, sizeof h.socket_path);
    if (n > 0 && n < sizeof h.socket_path) return std::string(h.socket_path, n);
  }
  return default_socket_path(name);
}

namespace {

bool read_exact(int fd, std::string& out, size_t n, int64_t deadline) {
  out.clear();
  char buf[65536];
  while (out.size() < n) {
    const int64_t left_ms = (deadline - kernel_rt::monotonic_now_ns()) / 1000000;
    if (left_ms <= 0) return false;
    pollfd p{fd, POLLIN, 0};
    if (poll(&p, 1, static_cast<int>(left_ms)) <= 0) return false;
    const ssize_t got = recv(fd, buf, std::min(sizeof buf, n - out.size()), 0);
    if (got <= 0) return false;
    out.append(buf, static_cast<size_t>(got));
  }
  return true;
}

bool read_header_line(int fd, std::string& line, int64_t deadline) {
  line.clear();
  for (;;) {
    if (line.size() > kMaxHeader) return false;
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

// "drop=A,B" -> ["A", "B"]: the outputs a swap may leave out (--drop-output).
json drop_list(const std::string& word) {
  json out = json::array();
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

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> v;
  std::istringstream in(s);
  std::string w;
  while (in >> w) v.push_back(w);
  return v;
}

}  // namespace

Result<json> api_request(const std::string& socket_path, const json& request, const std::string& payload,
                         int timeout_ms) {
  sockaddr_un addr{};
  if (socket_path.size() >= sizeof addr.sun_path) return make_error("socket path too long");
  // Talk only to a socket root or we own: a socket another user put in our way
  // would receive our commands (and could answer anything).
  struct stat st {};
  if (lstat(socket_path.c_str(), &st) == 0 && st.st_uid != 0 && st.st_uid != geteuid() &&
      !socket_owner_trusted(socket_path, st.st_uid)) {
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
  const int64_t deadline = kernel_rt::monotonic_now_ns() + int64_t{timeout_ms} * 1000000;
  const bool sent = send_all(fd, frame(request, payload));
  std::string line, text, ignored;
  bool got_header = sent && read_header_line(fd, line, deadline);
  auto h = got_header ? parse_header(line) : Result<Header>(make_error("no answer"));
  // An answer counts only whole: one cut off (the runtime died or was stopped
  // mid-answer) is not taken for a whole one.
  const bool whole = h.ok() && h->json_bytes <= kMaxAnswerJson && read_exact(fd, text, h->json_bytes, deadline) &&
                     read_exact(fd, ignored, h->payload_bytes, deadline);
  close(fd);
  if (!got_header) return make_error("no answer from the runtime at " + socket_path);
  if (!h) return make_error("the peer at " + socket_path + " does not speak the rtplc operator API: " + h.error());
  if (!whole) {
    return make_error("the runtime's answer at " + socket_path +
                      " was cut off before its end; what it did is unknown: check with `rtplc status`");
  }
  json answer = json::parse(text, nullptr, false);
  if (answer.is_discarded() || !answer.is_object()) {
    return make_error("the runtime at " + socket_path + " answered something that is not a JSON object");
  }
  return answer;
}

Result<json> request_of_words(const std::string& line) {
  const std::vector<std::string> w = split(line);
  if (w.empty()) return make_error("empty request");
  const std::string& verb = w[0];
  auto wrong = [&] { return make_error("wrong number of arguments for '" + verb + "'"); };
  json args = json::object();
  std::string op = verb;
  if (verb == "ping" || verb == "whoami" || verb == "unforce_all" || verb == "stop" || verb == "stats") {
    if (w.size() != 1) return wrong();
  } else if (verb == "status") {
    if (w.size() > 2 || (w.size() == 2 && w[1] != "json")) return wrong();
  } else if (verb == "values") {
    if (w.size() > 2) return wrong();
    if (w.size() == 2) args["filter"] = w[1];
  } else if (verb == "set" || verb == "force") {
    if (w.size() != 3) return wrong();
    args["label"] = w[1];
    char* end = nullptr;
    const double v = std::strtod(w[2].c_str(), &end);
    // What is not a plain number goes as typed: the runtime refuses it with its reason.
    if (end != w[2].c_str() && *end == '\0' && std::isfinite(v)) args["value"] = v;
    else args["value"] = w[2];
  } else if (verb == "unforce") {
    if (w.size() != 2) return wrong();
    args["label"] = w[1];
  } else if (verb == "swap" || verb == "swap-check") {
    if (w.size() != 4 && !(w.size() == 5 && w[4].rfind("drop=", 0) == 0)) return wrong();
    if (verb == "swap-check") op = "swap_check";
    args["task"] = w[1];
    args["name"] = w[2];
    if (w.size() == 5) args["drop_outputs"] = drop_list(w[4]);
  } else if (verb == "rollback") {
    if (w.size() != 2 && !(w.size() == 3 && w[2].rfind("drop=", 0) == 0)) return wrong();
    args["task"] = w[1];
    if (w.size() == 3) args["drop_outputs"] = drop_list(w[2]);
  } else if (verb == "trace") {
    if (w.size() < 2) return wrong();
    args["labels"] = std::vector<std::string>(w.begin() + 1, w.end());
  } else if (verb == "trace-keep" || verb == "trace-end") {
    if (w.size() != 2) return wrong();
    op = verb == "trace-keep" ? "trace_keep" : "trace_end";
    args["token"] = w[1];
  } else if (verb == "audit") {
    if (w.size() > 2) return wrong();
    if (w.size() == 2) {
      char* end = nullptr;
      const long long n = std::strtoll(w[1].c_str(), &end, 10);
      if (*end != '\0' || end == w[1].c_str()) return make_error("audit takes a number of lines, 1 to 100000");
      args["lines"] = n;
    }
  } else {
    op = verb;  // the runtime names the ops it knows
  }
  return json{{"op", op}, {"args", args}};
}

std::string refusal_message(const json& answer, const std::string& fallback) {
  const json e = answer.contains("error") && answer["error"].is_object() ? answer["error"] : json::object();
  const std::string m = e.value("message", std::string());
  return m.empty() ? fallback : m;
}

Result<std::string> control_request(const std::string& socket_path, const std::string& line,
                                    const std::string& payload, int timeout_ms) {
  auto request = request_of_words(line);
  if (!request) return make_error(request.error());
  auto answer = api_request(socket_path, *request, payload, timeout_ms);
  if (!answer) return make_error(answer.error());
  const json& a = *answer;
  if (!a.value("ok", false)) return make_error(refusal_message(a, "the runtime refused the request"));
  const json r = a.contains("result") && a["result"].is_object() ? a["result"] : json::object();
  if (line == "status json" && r.contains("status")) return r["status"].dump(2) + "\n";
  std::string text = r.value("text", std::string());
  if (!text.empty() && text.back() != '\n') text += '\n';
  return text;
}

}  // namespace rtplc::sched
