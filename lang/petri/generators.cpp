// Philosophers and Kanban, the MCC's scalable P/T models (see generators.h).
#include "lang/petri/generators.h"

#include <charconv>
#include <string>

namespace rtplc::petri {
namespace {

// Every id below is fresh, so these cannot fail.
PlaceId place(Net& n, const std::string& id, uint32_t tokens) {
  return n.add_place(id, tokens).value();
}
TransitionId transition(Net& n, const std::string& id) {
  return n.add_transition(id).value();
}

}  // namespace

// Philosopher i thinks, takes one fork (left: Catch1, or right: Catch2), then the
// other, eats, and puts both back. Every fork is free or held by one of its two
// neighbours, and the forks fix the philosophers' states: hence 3^N markings.
Net philosophers(uint32_t n) {
  Net net("Philosophers-" + std::to_string(n));
  std::vector<PlaceId> think, fork, catch1, catch2, eat;
  for (uint32_t i = 1; i <= n; ++i) {
    const std::string k = std::to_string(i);
    think.push_back(place(net, "Think_" + k, 1));
    fork.push_back(place(net, "Fork_" + k, 1));
    catch1.push_back(place(net, "Catch1_" + k, 0));
    catch2.push_back(place(net, "Catch2_" + k, 0));
    eat.push_back(place(net, "Eat_" + k, 0));
  }
  for (uint32_t i = 0; i < n; ++i) {
    const std::string k = std::to_string(i + 1);
    const PlaceId left = fork[i];
    const PlaceId right = fork[(i + 1) % n];
    const TransitionId ff1a = transition(net, "FF1a_" + k);  // takes the left fork first
    net.add_input(think[i], ff1a);
    net.add_input(left, ff1a);
    net.add_output(ff1a, catch1[i]);
    const TransitionId ff1b = transition(net, "FF1b_" + k);  // takes the right fork first
    net.add_input(think[i], ff1b);
    net.add_input(right, ff1b);
    net.add_output(ff1b, catch2[i]);
    const TransitionId ff2a = transition(net, "FF2a_" + k);  // then the right one
    net.add_input(catch1[i], ff2a);
    net.add_input(right, ff2a);
    net.add_output(ff2a, eat[i]);
    const TransitionId ff2b = transition(net, "FF2b_" + k);  // then the left one
    net.add_input(catch2[i], ff2b);
    net.add_input(left, ff2b);
    net.add_output(ff2b, eat[i]);
    const TransitionId end = transition(net, "End_" + k);
    net.add_input(eat[i], end);
    net.add_output(end, think[i]);
    net.add_output(end, left);
    net.add_output(end, right);
  }
  return net;
}

// Four stations, each with N kanban cards (P_i). A part in machining (Pm_i) is
// either good (tok_i -> Pout_i) or sent back for rework (tredo_i -> Pback_i, then
// tback_i -> Pm_i). Station 1 feeds stations 2 and 3 together (tsynch1_23), which
// feed station 4 together (tsynch4_23); station 4's output leaves the system.
Net kanban(uint32_t n) {
  Net net("Kanban-" + std::to_string(n));
  PlaceId pm[5], pback[5], pout[5], p[5];
  for (int i = 1; i <= 4; ++i) {
    const std::string k = std::to_string(i);
    pm[i] = place(net, "Pm" + k, 0);
    pback[i] = place(net, "Pback" + k, 0);
    pout[i] = place(net, "Pout" + k, 0);
    p[i] = place(net, "P" + k, n);
  }
  for (int i = 1; i <= 4; ++i) {
    const std::string k = std::to_string(i);
    const TransitionId redo = transition(net, "tredo" + k);
    net.add_input(pm[i], redo);
    net.add_output(redo, pback[i]);
    const TransitionId ok = transition(net, "tok" + k);
    net.add_input(pm[i], ok);
    net.add_output(ok, pout[i]);
    const TransitionId back = transition(net, "tback" + k);
    net.add_input(pback[i], back);
    net.add_output(back, pm[i]);
  }
  const TransitionId in1 = transition(net, "tin1");
  net.add_input(p[1], in1);
  net.add_output(in1, pm[1]);
  const TransitionId s123 = transition(net, "tsynch1_23");
  net.add_input(pout[1], s123);
  net.add_input(p[2], s123);
  net.add_input(p[3], s123);
  net.add_output(s123, p[1]);
  net.add_output(s123, pm[2]);
  net.add_output(s123, pm[3]);
  const TransitionId s423 = transition(net, "tsynch4_23");
  net.add_input(pout[2], s423);
  net.add_input(pout[3], s423);
  net.add_input(p[4], s423);
  net.add_output(s423, p[2]);
  net.add_output(s423, p[3]);
  net.add_output(s423, pm[4]);
  const TransitionId out4 = transition(net, "tout4");
  net.add_input(pout[4], out4);
  net.add_output(out4, p[4]);
  return net;
}

Result<Net> generate(std::string_view spec) {
  const size_t dash = spec.rfind('-');
  if (dash == std::string_view::npos) {
    return make_error("'" + std::string(spec) +
                      "': write MODEL-N, e.g. philosophers-10 or kanban-5");
  }
  const std::string_view model = spec.substr(0, dash);
  const std::string_view num = spec.substr(dash + 1);
  uint32_t n = 0;
  auto [ptr, ec] = std::from_chars(num.data(), num.data() + num.size(), n);
  if (ec != std::errc() || ptr != num.data() + num.size() || n == 0 || n > 100000) {
    return make_error("'" + std::string(num) + "' is not a size from 1 to 100000");
  }
  if (model == "philosophers") {
    if (n < 2) return make_error("philosophers need at least 2 at the table");
    return philosophers(n);
  }
  if (model == "kanban") return kanban(n);
  return make_error("unknown model '" + std::string(model) + "' (known: philosophers, kanban)");
}

}  // namespace rtplc::petri
