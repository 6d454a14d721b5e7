// Simulated plants for the `sim` I/O driver (spec io-links.md, "The simulated
// plant"): the seed's 1/(s^2 + s + 1) and friends, integrated with 4th-order
// Runge-Kutta at a step finer than the control task. Used by `rtplc sim` (closed
// loop in virtual time) and by the runtime's sim driver thread (real time).
#pragma once

#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "common/result.h"

namespace rtplc::io {

class Plant {
 public:
  virtual ~Plant() = default;
  // Back to rest: every state zero (the output is then 0 for a strictly proper plant).
  virtual void reset() = 0;
  // Advances the plant by `h` seconds with the input held at `u` (zero-order hold).
  virtual void step(double u, double h) = 0;
  virtual double output() const = 0;
  // One line for humans, e.g. "1/(s^2 + 1 s + 1)".
  virtual std::string describe() const = 0;

  // A plant with several signals (the measuring tank): `rtplc sim` wires each
  // port input to the program's output channel of that label and each port
  // output to its input channel of that label. The single-input single-output
  // plants have no ports and use step() and output().
  virtual std::vector<std::string> port_inputs() const { return {}; }
  virtual std::vector<std::string> port_outputs() const { return {}; }
  // Advances by `h` seconds with port input k held at in[k].
  virtual void step_ports(const std::vector<double>& in, double h) { step(in.empty() ? 0 : in[0], h); }
  virtual double port_output(size_t k) const {
    (void)k;
    return output();
  }
};

// Builds a plant from a spec string:
//   second-order[:K=1,wn=1,zeta=0.5]   K wn^2 / (s^2 + 2 zeta wn s + wn^2)  (default: the seed's plant)
//   tf:NUM/DEN                         coefficients in descending powers of s, e.g. tf:1/1,1,1
//   fopdt[:K=1,T=5,L=1]                first order plus dead time K e^(-L s) / (T s + 1)
//   tank[:A=1,q=0,max=100]             integrating tank: A dh/dt = u - q, 0 <= h <= max
//   measuring-tank[:fill=0.2,drain=0.25,low=0.1,high=0.9,press=2]
//                                      the SFC example's tank (docs/sfc.md): ports
//                                      valve1, valve2, lamp1 in; LS1, LS2, PBS, level out
Result<std::unique_ptr<Plant>> make_plant(std::string_view spec);

// The integration step for a task period `dt`: 0.01 s, or finer so that at least
// ten steps fall in one period, chosen so a whole number of steps spans dt.
double plant_step_for(double dt, int* steps_per_period = nullptr);

inline constexpr const char* kDefaultPlant = "second-order";

// Help text listing the plant specs (for --help).
const char* plant_help();

}  // namespace rtplc::io
