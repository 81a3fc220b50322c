#pragma once
// Weak-form (integral) regression of the contact law: Eq. 1 integrated against smooth test
// functions, so that no acceleration is taken from the data (docs/identification.md §5).
//
// Around each contact episode a support [a, b] is laid, and on it test functions
//   psi_q(t) = (1 - s^2)^P s^q,  s = (2 t - a - b) / (b - a),  q = 0 .. Q - 1,
// which vanish with their first P - 1 derivatives at a and b. Integrating by parts twice,
//   int f_N psi dt = -int (m y psi'' - c_y y psi' + k_y y psi - m e w^2 sin(w t + phase) psi) dt
//   int f_x psi dt =  int (m x psi'' - c_x x psi' + k_x x psi - m e w^2 cos(w t + phase) psi) dt
// are linear in the displacements (the noise enters once, smoothed by psi''), and the law
// f_N = sum theta_j phi_j(z, z_dot) for z > 0 gives the rows
//   int f_N psi_q dt = sum_j theta_j int phi_j(z, z_dot) 1[z > 0] psi_q dt.
// The regressor integrals use the data's z and a first derivative z_dot (never a second), with
// the contact onset and separation located between samples, and z_dot^p unbiased for the probe
// noise (candidate_term::unbiased). The rows of an episode share their data, so their noise is
// correlated: Cov = sigma^2 L L' with L the linear map from y to the left sides; each episode's
// rows are whitened by its Cholesky factor, after which every row has noise variance `noise^2`.

#include <Eigen/Dense>
#include <vector>

#include "ref/identification/contact_forces.hpp"
#include "ref/identification/term_library.hpp"

#include "ref/model/settings.hpp"

namespace rubref {

struct weak_form_settings {
  // Defaults, ranges and reasons: the settings registry (scope "weak_form").
  int test_functions = default_count_of("weak_form", "test_functions");  // Q per episode: moments up to s^5 resolve the force pulse's shape
  // P: the trapezoid rule's error on y psi'' falls with the smoothness of psi at the support's
  // ends. Whitened rows of a noise-free 10 kHz rig record against the true law leave, relative
  // to their norm: P = 3 6.4 %, P = 4 0.29 %, P = 6 0.23 %, P = 8 0.24 % (measured).
  // tests/identification_test.cpp holds P = 6 below 1 %.
  int bump_power = default_count_of("weak_form", "bump_power");
  // Savitzky-Golay half-width for z_dot (the only derivative the weak form takes), degree 4 as
  // --sg-degree: z_dot's noise falls as the window widens, and windows never cross y = delta, so a
  // wide one is capped at the contact segment (~16 samples at 10 kHz here). Measured at 2 um
  // noise, 10 revolutions, 30 seeds: half-width 4 -> 6 -> 8 moves k1's bias +5.4 -> +4.0 -> +4.0 %
  // and its spread 6.4 -> 4.3 -> 4.5 %; 8 lets longer contacts (lower rates) benefit too.
  int velocity_half_width = default_count_of("weak_form", "velocity_half_width");
  // The support extends the episode by this share of its duration on each side (at least
  // 3 samples), so that onset and separation are interior and weighted fully.
  double margin = default_of("weak_form", "margin");
  void validate() const;  // input_error naming the setting
};

// One dwell's contact data for the weak form: its forces (z, z_dot, the source samples) and the
// standard deviation of its samples' white noise (sigma / sqrt(revolutions) for an average).
struct weak_form_input {
  const dwell_forces* forces = nullptr;
  double noise = 0.0;  // m
};

struct weak_form_system {
  Eigen::MatrixXd A;   // whitened regressor integrals (rows x library terms)
  Eigen::VectorXd b;   // whitened int f_N psi dt
  Eigen::VectorXd bx;  // the same whitening of int f_x psi dt
  std::vector<std::size_t> dwell_of_row;  // an episode's rows are test_functions consecutive ones
  std::size_t episodes = 0;
  double noise = 0.0;  // m: every whitened row's noise standard deviation (the dwells' sample noise)
};

// Throws input_error if no episode fits in its dwell with its support.
weak_form_system weak_form(const std::vector<weak_form_input>& dwells, const linear_part& lin,
                           const std::vector<candidate_term>& library, const weak_form_settings& s = {});

}  // namespace rubref

