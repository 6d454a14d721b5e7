// P-invariants by the Farkas algorithm and the structural bounds they give
// (see invariants.h).
#include "lang/petri/invariants.h"

#include <algorithm>
#include <numeric>

namespace rtplc::petri {
namespace {

struct Row {
  std::vector<int64_t> b;  // remaining columns of y^T B
  std::vector<int64_t> y;  // the combination of places
};

bool support_subset(const std::vector<int64_t>& a, const std::vector<int64_t>& b) {
  for (size_t i = 0; i < a.size(); ++i) {
    if (a[i] != 0 && b[i] == 0) return false;
  }
  return true;
}

void normalise(Row& r) {
  int64_t g = 0;
  for (int64_t v : r.y) g = std::gcd(g, v);
  for (int64_t v : r.b) g = std::gcd(g, v);
  if (g > 1) {
    for (int64_t& v : r.y) v /= g;
    for (int64_t& v : r.b) v /= g;
  }
}

// Keeps only rows whose support is not a proper superset of another's (and one of
// any rows with equal support).
void keep_minimal(std::vector<Row>& rows) {
  std::vector<bool> drop(rows.size(), false);
  for (size_t i = 0; i < rows.size(); ++i) {
    if (drop[i]) continue;
    for (size_t j = 0; j < rows.size(); ++j) {
      if (i == j || drop[j]) continue;
      if (support_subset(rows[j].y, rows[i].y)) {
        // j's support lies inside i's: i is not minimal unless the supports are
        // equal, in which case keep the first.
        if (!support_subset(rows[i].y, rows[j].y) || j < i) {
          drop[i] = true;
          break;
        }
      }
    }
  }
  std::vector<Row> kept;
  for (size_t i = 0; i < rows.size(); ++i) {
    if (!drop[i]) kept.push_back(std::move(rows[i]));
  }
  rows = std::move(kept);
}

bool overflows(int64_t a, int64_t b) {
  int64_t out = 0;
  return __builtin_mul_overflow(a, b, &out);
}

}  // namespace

InvariantResult p_invariants(const Net& net, size_t max_rows) {
  const size_t m = net.place_count();
  const size_t n = net.transition_count();
  const IntMatrix b = net.incidence();
  InvariantResult res;
  std::vector<Row> rows(m);
  for (size_t i = 0; i < m; ++i) {
    rows[i].b.resize(n);
    for (size_t j = 0; j < n; ++j) rows[i].b[j] = b(i, j);
    rows[i].y.assign(m, 0);
    rows[i].y[i] = 1;
  }
  for (size_t j = 0; j < n && res.complete; ++j) {
    std::vector<Row> next;
    std::vector<size_t> pos, neg;
    for (size_t i = 0; i < rows.size(); ++i) {
      if (rows[i].b[j] == 0) next.push_back(rows[i]);
      if (rows[i].b[j] > 0) pos.push_back(i);
      if (rows[i].b[j] < 0) neg.push_back(i);
    }
    for (size_t ip : pos) {
      for (size_t in : neg) {
        const int64_t a = -rows[in].b[j];  // > 0
        const int64_t c = rows[ip].b[j];   // > 0
        const int64_t g = std::gcd(a, c);
        const int64_t fa = a / g, fc = c / g;
        Row r;
        r.b.resize(n);
        r.y.resize(m);
        bool bad = false;
        for (size_t k = 0; k < n && !bad; ++k) {
          bad = overflows(fa, rows[ip].b[k]) || overflows(fc, rows[in].b[k]);
          r.b[k] = fa * rows[ip].b[k] + fc * rows[in].b[k];
        }
        for (size_t k = 0; k < m && !bad; ++k) {
          bad = overflows(fa, rows[ip].y[k]) || overflows(fc, rows[in].y[k]);
          r.y[k] = fa * rows[ip].y[k] + fc * rows[in].y[k];
        }
        if (bad) {
          res.complete = false;
          continue;
        }
        normalise(r);
        next.push_back(std::move(r));
        if (next.size() > max_rows * 4) break;
      }
      if (next.size() > max_rows * 4) break;
    }
    keep_minimal(next);
    if (next.size() > max_rows) {
      res.complete = false;
      next.resize(max_rows);
    }
    rows = std::move(next);
  }
  std::vector<bool> covered(m, false);
  const Marking m0 = net.initial_marking();
  for (Row& r : rows) {
    if (!res.complete && std::any_of(r.b.begin(), r.b.end(), [](int64_t v) { return v != 0; })) {
      continue;  // a stopped computation leaves rows that are not invariants yet
    }
    PInvariant inv;
    inv.weights = std::move(r.y);
    for (size_t p = 0; p < m; ++p) {
      inv.token_sum += inv.weights[p] * int64_t{m0[p]};
      if (inv.weights[p] != 0) covered[p] = true;
    }
    res.invariants.push_back(std::move(inv));
  }
  res.covered = std::all_of(covered.begin(), covered.end(), [](bool c) { return c; });
  return res;
}

std::vector<std::optional<uint64_t>> structural_bounds(const Net& net, const InvariantResult& inv) {
  std::vector<std::optional<uint64_t>> bounds(net.place_count());
  for (const PInvariant& y : inv.invariants) {
    for (size_t p = 0; p < y.weights.size(); ++p) {
      if (y.weights[p] <= 0) continue;
      const auto b = static_cast<uint64_t>(y.token_sum / y.weights[p]);
      if (!bounds[p] || b < *bounds[p]) bounds[p] = b;
    }
  }
  return bounds;
}

std::string invariant_text(const Net& net, const PInvariant& y) {
  std::string s;
  for (size_t p = 0; p < y.weights.size(); ++p) {
    if (y.weights[p] == 0) continue;
    if (!s.empty()) s += " + ";
    if (y.weights[p] != 1) s += std::to_string(y.weights[p]) + "*";
    s += net.place_label(static_cast<PlaceId>(p));
  }
  return s + " = " + std::to_string(y.token_sum);
}

}  // namespace rtplc::petri
