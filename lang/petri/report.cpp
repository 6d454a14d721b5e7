// Runs the analysis of a net and renders it as text and JSON (see report.h).
#include "lang/petri/report.h"

#include <cinttypes>
#include <cmath>
#include <cstdio>

namespace rtplc::petri {
namespace {

// v with `decimals` digits after the point.
std::string fixed(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

std::string with_commas(uint64_t v) {
  const std::string digits = std::to_string(v);
  std::string s;
  for (size_t i = 0; i < digits.size(); ++i) {
    if (i > 0 && (digits.size() - i) % 3 == 0) s.push_back(',');
    s.push_back(digits[i]);
  }
  return s;
}

std::string json_string(std::string_view s) {
  std::string o = "\"";
  for (char c : s) {
    const auto u = static_cast<unsigned char>(c);
    if (c == '"' || c == '\\') {
      o += '\\';
      o += c;
    } else if (c == '\n') {
      o += "\\n";
    } else if (u < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", u);
      o += buf;
    } else {
      o += c;
    }
  }
  return o + "\"";
}

template <typename F>
std::string json_list(size_t n, F item) {
  std::string o = "[";
  for (size_t i = 0; i < n; ++i) o += (i ? ", " : "") + item(i);
  return o + "]";
}

std::string json_sequence(const Net& net, const std::vector<TransitionId>& seq) {
  return json_list(seq.size(), [&](size_t i) { return json_string(net.transition_label(seq[i])); });
}

// {"p1": 1, "p3": 2}: the marked places only.
std::string json_marking(const Net& net, const Marking& m, const std::vector<PlaceId>& omega = {}) {
  std::string o = "{";
  bool first = true;
  for (size_t p = 0; p < m.size(); ++p) {
    bool is_omega = false;
    for (PlaceId q : omega) is_omega = is_omega || q == p;
    if (m[p] == 0 && !is_omega) continue;
    o += (first ? "" : ", ") + json_string(net.place_label(static_cast<PlaceId>(p))) + ": " +
         (is_omega ? std::string("\"omega\"") : std::to_string(m[p]));
    first = false;
  }
  return o + "}";
}

const char* status_name(ExploreStatus s) {
  switch (s) {
    case ExploreStatus::kComplete:
      return "complete";
    case ExploreStatus::kLimit:
      return "limit";
    case ExploreStatus::kUnbounded:
      return "unbounded";
    case ExploreStatus::kTooManyTokens:
      return "too_many_tokens";
  }
  return "?";
}

double rate(const ReachabilityResult& r) {
  return r.seconds > 0 ? static_cast<double>(r.markings) / r.seconds : 0;
}

std::string omega_text(const Net& net, const Pump& pump) {
  std::string s;
  for (size_t p = 0; p < pump.start.size(); ++p) {
    bool grows = false;
    for (PlaceId q : pump.growing) grows = grows || q == p;
    if (!grows && pump.start[p] == 0) continue;
    if (!s.empty()) s += ", ";
    s += net.place_label(static_cast<PlaceId>(p));
    if (grows)
      s += "=omega";
    else if (pump.start[p] != 1)
      s += "*" + std::to_string(pump.start[p]);
  }
  return s;
}

}  // namespace

std::optional<bool> Analysis::bounded() const {
  if (reach.status == ExploreStatus::kUnbounded) return false;
  if (reach.status == ExploreStatus::kComplete || invariants.covered) return true;
  return std::nullopt;
}

Analysis analyze(const Net& net, const AnalysisOptions& options) {
  Analysis a;
  a.invariants = p_invariants(net);
  a.structural_bounds = structural_bounds(net, a.invariants);
  ExploreOptions eo;
  eo.max_markings = options.max_markings;
  eo.graph_limit = options.graph_limit;
  eo.threads = options.threads;
  eo.progress = options.progress;
  eo.place_bounds = a.structural_bounds;
  a.reach = explore(net, eo);
  a.max_markings = options.max_markings;
  return a;
}

std::string render_text(const Net& net, const Analysis& a) {
  const ReachabilityResult& r = a.reach;
  const size_t np = net.place_count(), nt = net.transition_count();
  std::string o;
  o += "net " + net.name() + ": " + std::to_string(np) + " places, " + std::to_string(nt) +
       " transitions, " + std::to_string(net.arc_count()) + " arcs\n";
  constexpr size_t kListMax = 60;
  o += "places:";
  for (size_t p = 0; p < np && p < kListMax; ++p) {
    o += " " + net.place_label(static_cast<PlaceId>(p));
    if (net.place(static_cast<PlaceId>(p)).initial)
      o += "(" + std::to_string(net.place(static_cast<PlaceId>(p)).initial) + ")";
  }
  if (np > kListMax) o += " ... (" + std::to_string(np - kListMax) + " more)";
  o += "\ntransitions:";
  for (size_t t = 0; t < nt && t < kListMax; ++t)
    o += " " + net.transition_label(static_cast<TransitionId>(t));
  if (nt > kListMax) o += " ... (" + std::to_string(nt - kListMax) + " more)";
  o += "\n\n";
  const IntMatrix b = net.incidence();
  if (np <= 60 && nt <= 30) {
    std::vector<std::string> pl, tl;
    for (size_t p = 0; p < np; ++p) pl.push_back(net.place_label(static_cast<PlaceId>(p)));
    for (size_t t = 0; t < nt; ++t)
      tl.push_back(net.transition_label(static_cast<TransitionId>(t)));
    o += "incidence matrix B = B+ - B- (rows: places, columns: transitions):\n" +
         b.to_string(pl, tl) + "\n";
  } else {
    o += "incidence matrix B: " + std::to_string(np) + " x " + std::to_string(nt) + ", " +
         std::to_string(b.nonzero_count()) +
         " non-zero entries (too wide to print; --json has it)\n\n";
  }

  switch (r.status) {
    case ExploreStatus::kComplete:
      o += "reachability graph: complete\n";
      break;
    case ExploreStatus::kLimit:
      o += "reachability graph: STOPPED at the limit of " + with_commas(a.max_markings) +
           " markings (--limit); the figures below are lower bounds\n";
      break;
    case ExploreStatus::kUnbounded:
      o += "reachability graph: infinite (the net is unbounded, see below)\n";
      break;
    case ExploreStatus::kTooManyTokens:
      o += "reachability graph: STOPPED: place " + r.overflow_place +
           " holds more tokens than its storage field (no P-invariant bounds it)\n";
      break;
  }
  o += "  markings:   " + with_commas(r.markings) + "\n";
  o += "  edges:      " + with_commas(r.edges) + " (firings)\n";
  o += "  time:       " + fixed(r.seconds, 3) + " s" + ", " + fixed(rate(r) / 1e6, 2) +
       " million markings/s, " + fixed(r.bytes_per_marking(), 1) + " bytes/marking (" +
       std::to_string(r.key_bits) + " bits of tokens in " + std::to_string(r.key_words) + " word" +
       (r.key_words == 1 ? "" : "s") + ")" +
       (r.threads > 1 ? ", " + std::to_string(r.threads) + " threads" : std::string()) + "\n";
  const std::optional<bool> bounded = a.bounded();
  o += "  bounded:    " + std::string(!bounded ? "unknown" : *bounded ? "yes" : "NO") + "\n";
  if (r.status != ExploreStatus::kUnbounded) {
    o += "  bound:      " + std::to_string(r.max_tokens_in_place) + " token" +
         (r.max_tokens_in_place == 1 ? "" : "s") + " at most in one place" +
         (r.exact() ? "" : " (so far)") + (r.safe() ? " (safe)" : " (not safe)") + "\n";
  }

  if (r.pump) {
    const Pump& pm = *r.pump;
    std::string grow;
    for (PlaceId p : pm.growing) {
      grow += (grow.empty() ? "" : ", ") + net.place_label(p) + " +" +
              std::to_string(pm.end[p] - pm.start[p]);
    }
    o += "\nunbounded: each round of the pumping sequence adds tokens (" + grow + ")\n";
    o += "  reach:    " + sequence_text(net, pm.prefix) + "\n";
    o += "  then pump: " + sequence_text(net, pm.cycle) + "   (repeat forever)\n";
    o += "  omega marking: " + omega_text(net, pm) + "\n";
  }

  o += "\ndead markings (deadlocks): " + with_commas(r.dead_markings) +
       (r.exact() ? "" : " found so far") + "\n";
  for (size_t i = 0; i < r.dead_examples.size(); ++i) {
    const DeadMarking& d = r.dead_examples[i];
    o += "  " + std::to_string(i + 1) + ". " + marking_text(net, d.marking) + "\n     after " +
         std::to_string(d.path.size()) + " firing" + (d.path.size() == 1 ? "" : "s") + ": " +
         sequence_text(net, d.path) + "\n";
  }
  if (r.dead_markings > r.dead_examples.size()) {
    o += "  (" + with_commas(r.dead_markings - r.dead_examples.size()) + " more not shown)\n";
  }

  std::string dead;
  size_t n_dead = 0;
  for (size_t t = 0; t < nt; ++t) {
    if (r.fired[t]) continue;
    ++n_dead;
    if (n_dead <= kListMax) dead += " " + net.transition_label(static_cast<TransitionId>(t));
  }
  o += "dead transitions" + std::string(r.exact() ? "" : " (not fired in the part explored)") +
       ": " + (n_dead == 0 ? std::string("none") : std::to_string(n_dead) + ":" + dead) + "\n";

  o += "\nP-invariants: " + std::to_string(a.invariants.invariants.size()) +
       (a.invariants.complete ? "" : " (computation stopped early: too many)") +
       (a.invariants.covered ? ", every place covered (structurally bounded)" : "") + "\n";
  for (size_t i = 0; i < a.invariants.invariants.size() && i < 40; ++i) {
    o += "  " + invariant_text(net, a.invariants.invariants[i]) + "\n";
  }
  if (a.invariants.invariants.size() > 40) o += "  ...\n";
  return o;
}

std::string render_json(const Net& net, const Analysis& a) {
  const ReachabilityResult& r = a.reach;
  const size_t np = net.place_count(), nt = net.transition_count();
  std::string o = "{\n";
  auto field = [&o](const std::string& name, const std::string& value) {
    o += "  " + json_string(name) + ": " + value + ",\n";
  };
  field("net", json_string(net.name()));
  field("places", std::to_string(np));
  field("transitions", std::to_string(nt));
  field("arcs", std::to_string(net.arc_count()));
  field("place_names", json_list(np, [&](size_t p) {
          return json_string(net.place_label(static_cast<PlaceId>(p)));
        }));
  field("transition_names", json_list(nt, [&](size_t t) {
          return json_string(net.transition_label(static_cast<TransitionId>(t)));
        }));
  const Marking m0 = net.initial_marking();
  field("initial_marking", json_list(np, [&](size_t p) { return std::to_string(m0[p]); }));
  if (np * nt <= 1'000'000) {
    const IntMatrix b = net.incidence();
    field("incidence", json_list(np, [&](size_t p) {
            return json_list(nt, [&](size_t t) { return std::to_string(b(p, t)); });
          }));
  }
  field("status", json_string(status_name(r.status)));
  field("exact", r.exact() ? "true" : "false");
  const std::optional<bool> bounded = a.bounded();
  field("bounded", !bounded ? "null" : *bounded ? "true" : "false");
  field("markings", std::to_string(r.markings));
  field("edges", std::to_string(r.edges));
  field("dead_markings", std::to_string(r.dead_markings));
  field("dead_marking_examples", json_list(r.dead_examples.size(), [&](size_t i) {
          return "{\"marking\": " + json_marking(net, r.dead_examples[i].marking) +
                 ", \"sequence\": " + json_sequence(net, r.dead_examples[i].path) + "}";
        }));
  field("max_tokens_in_place", std::to_string(r.max_tokens_in_place));
  field("place_max_tokens",
        json_list(np, [&](size_t p) { return std::to_string(r.max_tokens[p]); }));
  field("safe", r.status != ExploreStatus::kUnbounded && r.safe() ? "true" : "false");
  std::vector<TransitionId> dead;
  for (size_t t = 0; t < nt; ++t) {
    if (!r.fired[t]) dead.push_back(static_cast<TransitionId>(t));
  }
  field("dead_transitions", json_sequence(net, dead));
  field("p_invariants", json_list(a.invariants.invariants.size(), [&](size_t i) {
          const PInvariant& y = a.invariants.invariants[i];
          std::string w = "{";
          bool first = true;
          for (size_t p = 0; p < y.weights.size(); ++p) {
            if (y.weights[p] == 0) continue;
            w += (first ? "" : ", ") + json_string(net.place_label(static_cast<PlaceId>(p))) +
                 ": " + std::to_string(y.weights[p]);
            first = false;
          }
          return "{\"weights\": " + w + "}, \"tokens\": " + std::to_string(y.token_sum) + "}";
        }));
  field("p_invariants_complete", a.invariants.complete ? "true" : "false");
  if (r.pump) {
    const Pump& pm = *r.pump;
    field("pump",
          "{\"prefix\": " + json_sequence(net, pm.prefix) +
              ", \"cycle\": " + json_sequence(net, pm.cycle) + ", \"growing\": " +
              json_list(pm.growing.size(),
                        [&](size_t i) { return json_string(net.place_label(pm.growing[i])); }) +
              ", \"omega_marking\": " + json_marking(net, pm.start, pm.growing) + "}");
  } else {
    field("pump", "null");
  }
  if (r.status == ExploreStatus::kTooManyTokens)
    field("overflow_place", json_string(r.overflow_place));
  field("seconds", fixed(r.seconds, 6));
  field("markings_per_second", fixed(rate(r), 0));
  field("threads", std::to_string(r.threads));
  o += "  \"bytes_per_marking\": " + fixed(r.bytes_per_marking(), 2) + "\n}\n";
  return o;
}

}  // namespace rtplc::petri
