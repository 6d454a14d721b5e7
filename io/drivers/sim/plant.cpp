// Plant models for simulation (see plant.h). Linear plants are integrated in
// controllable canonical state-space form with classic RK4; the dead time of
// FOPDT is a ring of past inputs at the integration step.
#include "io/drivers/sim/plant.h"

#include "common/text.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>

namespace rtplc::io {
namespace {


// x' = A x + B u, y = C x + D u with A in companion form, built from a proper
// transfer function format_number(s)/den(s).
class TransferFunction final : public Plant {
 public:
  TransferFunction(std::vector<double> num_c, std::vector<double> den_c)
      : num_(std::move(num_c)), den_(std::move(den_c)) {
    const double a0 = den_.front();
    for (double& c : den_) c /= a0;
    for (double& c : num_) c /= a0;
    n_ = den_.size() - 1;
    // Pad the numerator to n+1 coefficients (descending powers).
    std::vector<double> b(n_ + 1, 0.0);
    std::copy(num_.begin(), num_.end(), b.end() - static_cast<long>(num_.size()));
    d_ = b[0];
    c_.assign(n_, 0.0);
    // y = sum_i (b_{n-i} - a_{n-i} b0) x_{i} with x_0 the lowest derivative.
    for (size_t i = 0; i < n_; ++i) c_[i] = b[n_ - i] - den_[n_ - i] * d_;
    x_.assign(n_, 0.0);
    k_.assign(4, std::vector<double>(n_, 0.0));
    tmp_.assign(n_, 0.0);
  }

  void reset() override { std::fill(x_.begin(), x_.end(), 0.0); }

  void step(double u, double h) override {
    if (n_ == 0) {
      u_ = u;
      return;
    }
    deriv(x_, u, k_[0]);
    for (size_t i = 0; i < n_; ++i) tmp_[i] = x_[i] + 0.5 * h * k_[0][i];
    deriv(tmp_, u, k_[1]);
    for (size_t i = 0; i < n_; ++i) tmp_[i] = x_[i] + 0.5 * h * k_[1][i];
    deriv(tmp_, u, k_[2]);
    for (size_t i = 0; i < n_; ++i) tmp_[i] = x_[i] + h * k_[2][i];
    deriv(tmp_, u, k_[3]);
    for (size_t i = 0; i < n_; ++i) {
      x_[i] += h / 6.0 * (k_[0][i] + 2.0 * k_[1][i] + 2.0 * k_[2][i] + k_[3][i]);
    }
    u_ = u;
  }

  double output() const override {
    double y = d_ * u_;
    for (size_t i = 0; i < n_; ++i) y += c_[i] * x_[i];
    return y;
  }

  std::string describe() const override {
    // (2 s + 1)/(s^2 + 3 s + 1): a numerator of several terms needs its own parentheses.
    const std::string n = poly(num_);
    const bool terms = n.find(" + ") != std::string::npos || n.find(" - ") != std::string::npos;
    return (terms ? "(" + n + ")" : n) + "/(" + poly(den_) + ")";
  }

 private:
  void deriv(const std::vector<double>& x, double u, std::vector<double>& dx) const {
    for (size_t i = 0; i + 1 < n_; ++i) dx[i] = x[i + 1];
    double last = u;
    for (size_t i = 0; i < n_; ++i) last -= den_[n_ - i] * x[i];
    dx[n_ - 1] = last;
  }

  static std::string poly(const std::vector<double>& c) {
    std::string s;
    const size_t deg = c.size() - 1;
    for (size_t i = 0; i < c.size(); ++i) {
      if (c[i] == 0) continue;
      const size_t p = deg - i;
      if (!s.empty()) s += c[i] < 0 ? " - " : " + ";
      else if (c[i] < 0) s += "-";
      double a = std::fabs(c[i]);
      if (a != 1 || p == 0) s += format_number(a);
      if (p >= 1) s += (a != 1 ? " s" : "s");
      if (p >= 2) s += "^" + std::to_string(p);
    }
    return s.empty() ? "0" : s;
  }

  std::vector<double> num_, den_;
  size_t n_ = 0;
  double d_ = 0;
  std::vector<double> c_;
  std::vector<double> x_;
  std::vector<std::vector<double>> k_;
  std::vector<double> tmp_;
  double u_ = 0;
};

class Fopdt final : public Plant {
 public:
  Fopdt(double k, double t, double l) : k_(k), t_(t), l_(l) {}
  void reset() override {
    x_ = 0;
    ring_.clear();
    head_ = 0;
  }
  void step(double u, double h) override {
    // Dead time as a ring of inputs at this step size; rebuilt if h changes.
    const auto n = static_cast<size_t>(std::llround(l_ / h));
    if (ring_.size() != n) {
      ring_.assign(n, 0.0);
      head_ = 0;
    }
    double ud = u;
    if (n > 0) {
      ud = ring_[head_];
      ring_[head_] = u;
      head_ = (head_ + 1) % n;
    }
    // RK4 of x' = (K ud - x)/T with ud held over the step.
    auto f = [&](double x) { return (k_ * ud - x) / t_; };
    const double k1 = f(x_), k2 = f(x_ + 0.5 * h * k1), k3 = f(x_ + 0.5 * h * k2),
                 k4 = f(x_ + h * k3);
    x_ += h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4);
  }
  double output() const override { return x_; }
  std::string describe() const override {
    return format_number(k_) + " e^(-" + format_number(l_) + " s)/(" + format_number(t_) + " s + 1)";
  }

 private:
  double k_, t_, l_;
  double x_ = 0;
  std::vector<double> ring_;
  size_t head_ = 0;
};

class Tank final : public Plant {
 public:
  Tank(double area, double q, double max) : a_(area), q_(q), max_(max) {}
  void reset() override { h_ = 0; }
  void step(double u, double h) override { h_ = std::clamp(h_ + h * (u - q_) / a_, 0.0, max_); }
  double output() const override { return h_; }
  std::string describe() const override {
    return "tank: " + format_number(a_) + " dh/dt = u - " + format_number(q_) + ", 0 <= h <= " + format_number(max_);
  }

 private:
  double a_, q_, max_;
  double h_ = 0;
};

// The measuring tank of the SFC example (docs/sfc.md, "The measuring tank"):
// the level h (0 empty .. 1 full) rises at `fill` per second while valve 1 is
// open and falls at `drain` while valve 2 is; LS2 is on at h <= low, LS1 at
// h >= high. The operator is part of the plant: `press` seconds after the lamp
// comes on they press the latching push button, and let go of it once the
// lamp goes out.
class MeasuringTank final : public Plant {
 public:
  MeasuringTank(double fill, double drain, double low, double high, double press)
      : fill_(fill), drain_(drain), low_(low), high_(high), press_(press) {}
  void reset() override {
    h_ = 0;
    lamp_s_ = 0;
    pbs_ = false;
  }
  void step(double u, double h) override { step_ports({u, 0, 0}, h); }
  double output() const override { return h_; }
  std::string describe() const override {
    return "measuring tank: fill " + format_number(fill_) + "/s, drain " + format_number(drain_) +
           "/s, LS2 at <= " + format_number(low_) + ", LS1 at >= " + format_number(high_) +
           ", PBS pressed " + format_number(press_) + " s after the lamp";
  }
  std::vector<std::string> port_inputs() const override { return {"valve1", "valve2", "lamp1"}; }
  std::vector<std::string> port_outputs() const override { return {"LS1", "LS2", "PBS", "level"}; }
  void step_ports(const std::vector<double>& in, double h) override {
    const bool v1 = !in.empty() && in[0] != 0, v2 = in.size() > 1 && in[1] != 0,
               lamp = in.size() > 2 && in[2] != 0;
    h_ = std::clamp(h_ + h * ((v1 ? fill_ : 0.0) - (v2 ? drain_ : 0.0)), 0.0, 1.0);
    lamp_s_ = lamp ? lamp_s_ + h : 0.0;
    if (lamp && lamp_s_ >= press_) pbs_ = true;
    if (!lamp) pbs_ = false;
  }
  double port_output(size_t k) const override {
    switch (k) {
      case 0:
        return h_ >= high_ ? 1 : 0;
      case 1:
        return h_ <= low_ ? 1 : 0;
      case 2:
        return pbs_ ? 1 : 0;
      default:
        return h_;
    }
  }

 private:
  double fill_, drain_, low_, high_, press_;
  double h_ = 0;
  double lamp_s_ = 0;  // how long the lamp has been on
  bool pbs_ = false;
};

Result<std::map<std::string, double>> parse_kv(std::string_view text,
                                               const std::map<std::string, double>& defaults) {
  std::map<std::string, double> out = defaults;
  size_t i = 0;
  while (i < text.size()) {
    size_t comma = text.find(',', i);
    if (comma == std::string_view::npos) comma = text.size();
    std::string_view item = text.substr(i, comma - i);
    size_t eq = item.find('=');
    if (eq == std::string_view::npos) return make_error("expected NAME=VALUE, found '" + std::string(item) + "'");
    std::string key(item.substr(0, eq));
    if (!defaults.count(key)) {
      std::string known;
      for (auto& [k, v] : defaults) known += (known.empty() ? "" : ", ") + k;
      return make_error("unknown plant parameter '" + key + "' (known: " + known + ")");
    }
    std::string val(item.substr(eq + 1));
    char* end = nullptr;
    double v = std::strtod(val.c_str(), &end);
    if (val.empty() || *end != '\0' || !std::isfinite(v)) {
      return make_error("plant parameter " + key + ": '" + val + "' is not a number");
    }
    out[key] = v;
    i = comma + 1;
  }
  return out;
}

Result<std::vector<double>> parse_coeffs(std::string_view text) {
  std::vector<double> c;
  size_t i = 0;
  while (i <= text.size()) {
    size_t comma = text.find(',', i);
    if (comma == std::string_view::npos) comma = text.size();
    std::string item(text.substr(i, comma - i));
    char* end = nullptr;
    double v = std::strtod(item.c_str(), &end);
    if (item.empty() || *end != '\0' || !std::isfinite(v)) {
      return make_error("'" + item + "' is not a coefficient");
    }
    c.push_back(v);
    i = comma + 1;
  }
  return c;
}

}  // namespace

const char* plant_help() {
  return "  second-order[:K=1,wn=1,zeta=0.5]  K wn^2/(s^2 + 2 zeta wn s + wn^2); the default is\n"
         "                                    the seed's plant 1/(s^2 + s + 1)\n"
         "  tf:NUM/DEN                        transfer function, coefficients in descending\n"
         "                                    powers of s: tf:1/1,1,1 is 1/(s^2 + s + 1)\n"
         "  fopdt[:K=1,T=5,L=1]               first order plus dead time K e^(-L s)/(T s + 1)\n"
         "  tank[:A=1,q=0,max=100]            integrating tank: A dh/dt = u - q, 0 <= h <= max\n"
         "  measuring-tank[:fill=0.2,drain=0.25,low=0.1,high=0.9,press=2]\n"
         "                                    the SFC example's tank (examples/tank.sfc):\n"
         "                                    reads the outputs valve1, valve2, lamp1, drives\n"
         "                                    the inputs LS1, LS2 and PBS (the operator presses\n"
         "                                    it press s after the lamp comes on); the CSV gets\n"
         "                                    plant.level\n";
}

Result<std::unique_ptr<Plant>> make_plant(std::string_view spec) {
  std::string_view kind = spec.substr(0, spec.find(':'));
  std::string_view rest = spec.size() > kind.size() ? spec.substr(kind.size() + 1) : "";
  if (kind == "second-order") {
    auto kv = parse_kv(rest, {{"K", 1.0}, {"wn", 1.0}, {"zeta", 0.5}});
    if (!kv) return make_error(kv.error());
    const double k = kv->at("K"), wn = kv->at("wn"), z = kv->at("zeta");
    if (!(wn > 0) || !(z >= 0)) return make_error("second-order needs wn > 0 and zeta >= 0");
    return std::unique_ptr<Plant>(
        new TransferFunction({k * wn * wn}, {1.0, 2.0 * z * wn, wn * wn}));
  }
  if (kind == "tf") {
    size_t slash = rest.find('/');
    if (slash == std::string_view::npos) return make_error("tf needs NUM/DEN, e.g. tf:1/1,1,1");
    auto num_c = parse_coeffs(rest.substr(0, slash));
    auto den_c = parse_coeffs(rest.substr(slash + 1));
    if (!num_c) return make_error("tf numerator: " + num_c.error());
    if (!den_c) return make_error("tf denominator: " + den_c.error());
    if (den_c->front() == 0) return make_error("tf: the leading denominator coefficient is 0");
    if (num_c->size() > den_c->size()) {
      return make_error("tf: the numerator's degree exceeds the denominator's (not proper)");
    }
    if (den_c->size() > 12) return make_error("tf: degree above 11 is not supported");
    return std::unique_ptr<Plant>(new TransferFunction(*num_c, *den_c));
  }
  if (kind == "fopdt") {
    auto kv = parse_kv(rest, {{"K", 1.0}, {"T", 5.0}, {"L", 1.0}});
    if (!kv) return make_error(kv.error());
    if (!(kv->at("T") > 0) || !(kv->at("L") >= 0) || kv->at("L") > 3600) {
      return make_error("fopdt needs T > 0 and 0 <= L <= 3600");
    }
    return std::unique_ptr<Plant>(new Fopdt(kv->at("K"), kv->at("T"), kv->at("L")));
  }
  if (kind == "tank") {
    auto kv = parse_kv(rest, {{"A", 1.0}, {"q", 0.0}, {"max", 100.0}});
    if (!kv) return make_error(kv.error());
    if (!(kv->at("A") > 0) || !(kv->at("max") > 0)) return make_error("tank needs A > 0, max > 0");
    return std::unique_ptr<Plant>(new Tank(kv->at("A"), kv->at("q"), kv->at("max")));
  }
  if (kind == "measuring-tank") {
    auto kv = parse_kv(
        rest, {{"fill", 0.2}, {"drain", 0.25}, {"low", 0.1}, {"high", 0.9}, {"press", 2.0}});
    if (!kv) return make_error(kv.error());
    const double fill = kv->at("fill"), drain = kv->at("drain"), low = kv->at("low"),
                 high = kv->at("high");
    if (!(fill > 0) || !(drain > 0) || !(low >= 0) || !(high <= 1) || !(low < high) ||
        !(kv->at("press") >= 0)) {
      return make_error(
          "measuring-tank needs fill > 0, drain > 0, 0 <= low < high <= 1 and press >= 0");
    }
    return std::unique_ptr<Plant>(new MeasuringTank(fill, drain, low, high, kv->at("press")));
  }
  return make_error("unknown plant '" + std::string(kind) + "'; choose one of:\n" + plant_help());
}

double plant_step_for(double dt, int* steps_per_period) {
  int n = std::max(10, static_cast<int>(std::ceil(dt / 0.01 - 1e-9)));
  if (steps_per_period) *steps_per_period = n;
  return dt / n;
}

}  // namespace rtplc::io
