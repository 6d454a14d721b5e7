// `rtplc web`: the operator's console in the browser, and `rtplc web user
// add|del|list|passwd`, the users who may log in to it (web/server.h, docs/web.md).
#include <CLI/CLI.hpp>
#include <signal.h>
#include <termios.h>
#include <unistd.h>

#include <cstdio>
#include <iostream>
#include <memory>
#include <string>

#include "app/arguments.h"
#include "app/commands.h"
#include "kernel_rt/rt_thread.h"
#include "sched/control.h"
#include "web/server.h"
#include "web/users.h"

namespace rtplc::app {
namespace {

struct WebArgs {
  std::string name = "rtplc";
  std::string socket;
  std::string listen = "127.0.0.1:8480";
  std::string tls_cert, tls_key;
  std::string users;
  std::string user, role = "viewer";
  bool password_stdin = false;
  bool no_link = false;
  std::string workspace;
};


web::UserFile users_of(const WebArgs& a) {
  return web::UserFile(a.users.empty() ? web::default_users_path(a.name) : a.users);
}

// A password from stdin (one line) or asked twice on the terminal without echo.
std::string read_password(const WebArgs& a) {
  std::string p;
  if (a.password_stdin || !isatty(STDIN_FILENO)) {
    if (!std::getline(std::cin, p)) fail("rtplc web user: no password on stdin", kExitUsage);
    return p;
  }
  termios old{};
  tcgetattr(STDIN_FILENO, &old);
  termios quiet = old;
  quiet.c_lflag &= ~static_cast<tcflag_t>(ECHO);
  auto ask = [&](const char* prompt) {
    std::fprintf(stderr, "%s", prompt);
    tcsetattr(STDIN_FILENO, TCSANOW, &quiet);
    std::string line;
    std::getline(std::cin, line);
    tcsetattr(STDIN_FILENO, TCSANOW, &old);
    std::fprintf(stderr, "\n");
    return line;
  };
  p = ask("password for the console: ");
  if (ask("again: ") != p) fail("rtplc web user: the two passwords differ; nothing changed", kExitUsage);
  return p;
}

void run_user(const WebArgs& a, const std::string& verb) {
  web::UserFile f = users_of(a);
  if (verb == "list") {
    auto users = f.load();
    if (!users) fail("rtplc web user list: " + users.error());
    if (users->empty()) {
      std::printf("no users in %s (rtplc web user add NAME --role ROLE)\n", f.path().c_str());
      return;
    }
    for (const web::WebUser& u : *users) std::printf("%-32s %s\n", u.name.c_str(), role_name(u.role));
    return;
  }
  if (a.user.empty()) fail("rtplc web user " + verb + " NAME", kExitUsage);
  if (verb == "del") {
    if (auto r = f.remove(a.user); !r) fail("rtplc web user del: " + r.error());
    std::printf("user %s removed from %s (sessions already open end within the console's idle time)\n",
                a.user.c_str(), f.path().c_str());
    return;
  }
  const auto role = parse_role(a.role);
  if (!role) fail("rtplc web user: --role takes viewer, operator, engineer or admin", kExitUsage);
  const std::string password = read_password(a);
  if (verb == "add") {
    if (auto r = f.add(a.user, *role, password); !r) fail("rtplc web user add: " + r.error());
    std::printf("user %s (%s) added to %s\n", a.user.c_str(), role_name(*role), f.path().c_str());
  } else {
    if (auto r = f.set_password(a.user, password); !r) fail("rtplc web user passwd: " + r.error());
    std::printf("password of %s changed in %s\n", a.user.c_str(), f.path().c_str());
  }
}

void run_web(const WebArgs& a) {
  web::WebOptions o;
  o.runtime_name = a.name;
  o.socket = a.socket;
  o.tls_cert = a.tls_cert;
  o.tls_key = a.tls_key;
  o.users_path = a.users;
  o.workspace = a.workspace;
  const size_t colon = a.listen.rfind(':');
  if (colon == std::string::npos || colon == 0) fail("rtplc web: --listen takes HOST:PORT, e.g. 127.0.0.1:8480", kExitUsage);
  o.host = a.listen.substr(0, colon);
  if (o.host.size() > 2 && o.host.front() == '[' && o.host.back() == ']') o.host = o.host.substr(1, o.host.size() - 2);
  char* end = nullptr;
  const long port = std::strtol(a.listen.c_str() + colon + 1, &end, 10);
  if (*end != '\0' || port < 0 || port > 65535) fail("rtplc web: '" + a.listen + "' has no port number", kExitUsage);
  o.port = static_cast<int>(port);
  // Signals are taken by one thread (below); every other thread has them blocked.
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);
  signal(SIGPIPE, SIG_IGN);
  web::WebConsole console(o);
  if (auto r = console.start(); !r) fail("rtplc web: " + r.error());
  std::printf("rtplc web: the console of runtime %s\n", a.name.c_str());
  if (a.no_link) {
    // A service: its output goes to a journal others may read, so no admin link there.
    std::printf("  serving %s:%d; no login link (--no-link): users log in with their passwords\n", o.host.c_str(),
                console.port());
  } else {
    const std::string link = console.login_link();
    std::printf("  open this link to log in as the runtime's owner (admin); it works once, within 10 minutes:\n");
    std::printf("  %s\n", link.c_str());
  }
  auto users = users_of(a).load();
  std::printf("  others log in as users of %s (%zu now; rtplc web user add NAME --role ROLE)\n",
              users_of(a).path().c_str(), users ? users->size() : size_t{0});
  if (!sched::api_request(sched::control_socket_of(a.name, a.socket), {{"op", "ping"}}, "", 2000)) {
    std::printf("  note: runtime %s does not answer now; the console shows it STALE until it runs\n", a.name.c_str());
  }
  std::fflush(stdout);
  kernel_rt::ThreadSpec spec;
  spec.name = "rtplc:web-sig";
  auto waiter = kernel_rt::start_thread(spec, [&console, stop_signals] {
    int sig = 0;
    sigwait(&stop_signals, &sig);
    console.stop();
  });
  if (!waiter) fail("rtplc web: " + waiter.error());
  console.run();
  // run() returns after stop(); a stop from elsewhere leaves the waiter blocked: wake it.
  kill(getpid(), SIGTERM);
  waiter->join();
  std::printf("rtplc web: stopped\n");
}

}  // namespace

void add_web_command(CLI::App& app) {
  auto a = std::make_shared<WebArgs>();
  CLI::App* web = app.add_subcommand("web", "The operator's console in a browser: live values, set, force, swap.");
  web->footer(
      "Serves the console of a running runtime on 127.0.0.1:8480 and prints a one-time link\n"
      "that logs its owner in as admin. Other people log in as users you add (rtplc web user\n"
      "add); their role (viewer, operator, engineer, admin) decides what they may do, and the\n"
      "runtime checks it again. Any address but loopback needs TLS. The console is its own\n"
      "process: it reads the image and asks the runtime, it never changes a task's timing.\n"
      "docs/web.md has every page and route.\n"
      "Examples:\n"
      "  rtplc run examples/seed_pid.yaml &\n"
      "  rtplc web\n"
      "  rtplc web --workspace ~/plc              # the FBD editor opens and saves there\n"
      "  rtplc web user add alice --role operator\n"
      "  rtplc web --listen 0.0.0.0:8443 --tls-cert c.pem --tls-key k.pem");
  web->add_option("--name", a->name, "runtime name (default rtplc)")->check(runtime_name());
  web->add_option("--socket", a->socket, "the runtime's control socket (default: found by name)");
  web->add_option("--listen", a->listen, "HOST:PORT to serve on (default 127.0.0.1:8480)");
  web->add_option("--tls-cert", a->tls_cert, "PEM certificate (needed for any address but loopback)");
  web->add_option("--tls-key", a->tls_key, "PEM private key of --tls-cert");
  web->add_option("--users", a->users, "the users file (default: NAME.web-users in the runtime's state folder)");
  web->add_option("--workspace", a->workspace,
                  "the FBD editor's folder of .fbd files (created if missing; without it: upload and download)");
  web->add_flag("--no-link", a->no_link,
                "print no one-time admin link (a service, whose output others may read); users log in");
  web->callback([a, web] {
    if (web->get_subcommands().empty()) run_web(*a);
  });

  CLI::App* user = web->add_subcommand("user", "Manage who may log in to the console: add, del, list, passwd.");
  user->require_subcommand(1);
  user->footer("Passwords are stored as Argon2id hashes (libsodium); there is no default account.\n"
               "Examples:\n  rtplc web user add alice --role operator\n"
               "  echo 'long passphrase' | rtplc web user add ci --role viewer --password-stdin\n"
               "  rtplc web user list\n  rtplc web user del alice");
  for (const char* verb : {"add", "del", "list", "passwd"}) {
    CLI::App* v = user->add_subcommand(verb, std::string(verb) == "add"      ? "Add a user with a role."
                                             : std::string(verb) == "del"    ? "Remove a user."
                                             : std::string(verb) == "list"   ? "List the users and their roles."
                                                                             : "Change a user's password.");
    if (std::string(verb) != "list") v->add_option("name", a->user, "user name")->required();
    if (std::string(verb) == "add") {
      v->add_option("--role", a->role, "viewer, operator, engineer or admin (default viewer)");
    }
    if (std::string(verb) == "add" || std::string(verb) == "passwd") {
      v->add_flag("--password-stdin", a->password_stdin, "read the password from stdin (for scripts)");
    }
    v->add_option("--name", a->name, "runtime name (default rtplc)")->check(runtime_name());
    v->add_option("--users", a->users, "the users file (default: NAME.web-users in the state folder)");
    const std::string which = verb;
    v->callback([a, which] { run_user(*a, which); });
  }
}

}  // namespace rtplc::app
