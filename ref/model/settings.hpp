#pragma once
// Every named setting rubref takes, in one table: its one spelling (the library's field, Python's
// keyword argument, `setting` in messages), the command line's flag, the file key, unit, default,
// valid range and why the range is what it is. validate(), the by-name look-ups, --help and the
// messages all read it; a setting is added here first (docs/architecture.md, "Settings").
//
// Rows are scoped by the algorithm that owns them: the same name may mean different things to
// two algorithms (a sweep's settle_revs starts from the neighbouring speed's steady state, a
// run's from rest) and then has a row in each; a scope without its own row uses the shared one
// (scope "").

#include <array>
#include <limits>
#include <string>
#include <string_view>

namespace rubref {

// The values a setting accepts: lo..hi, each end open or closed, optionally whole numbers only.
struct valid_range {
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  bool lo_open = false;
  bool hi_open = false;
  bool integer = false;
};

namespace range {
inline constexpr valid_range any{};
inline constexpr valid_range positive{.lo = 0.0, .lo_open = true};
inline constexpr valid_range non_negative{.lo = 0.0};
inline constexpr valid_range unit_interval{.lo = 0.0, .hi = 1.0};
constexpr valid_range at_least(double lo) { return {.lo = lo, .integer = true}; }
constexpr valid_range count_in(double lo, double hi) { return {.lo = lo, .hi = hi, .integer = true}; }
}  // namespace range

struct setting_info {
  std::string_view scope;        // the algorithm: "model", "run", "integration", "shooting", ...; "" shared
  std::string_view name;         // the one spelling: field, Python keyword, `setting` in messages
  std::string_view flag;         // the command-line flag without dashes
  std::string_view key;          // in parameter files and record metadata; "" when not written
  std::string_view unit;         // SI, or rpm / rev for speeds and revolution counts
  double default_value;
  valid_range range;
  std::string_view description;  // one line, for --help and docs
  std::string_view reason;       // why the range: the message a bad value gets ends with it
};

// clang-format off
inline constexpr auto settings_registry = std::to_array<setting_info>({
    // The model (Eq. 1-2, 6; §3 and Table 2 give the defaults).
    {"model", "m", "m", "m_kg", "kg", 1.52, range::positive, "rotor mass", "the equations of motion divide by it"},
    {"model", "e", "e", "e_m", "m", 0.0706e-3, range::non_negative, "mass eccentricity (unbalance m e omega^2)", "a distance"},
    {"model", "unbalance_phase", "unbalance-phase", "unbalance_phase_rad", "rad", 0.0, range::any,
     "angle of the unbalance from +x at t = 0: forcing m e omega^2 (cos(omega t + phase), sin(omega t + phase))", "an angle"},
    {"model", "c_x", "c-x", "c_x_kg_s", "kg/s", 15.100, range::non_negative, "damping, horizontal", "negative damping feeds energy in"},
    {"model", "c_y", "c-y", "c_y_kg_s", "kg/s", 14.727, range::non_negative, "damping, vertical", "negative damping feeds energy in"},
    {"model", "k_x", "k-x", "k_x_N_m", "N/m", 38.521e3, range::positive, "stiffness, horizontal", "a rotor without support stiffness has no orbit"},
    {"model", "k_y", "k-y", "k_y_N_m", "N/m", 41.017e3, range::positive, "stiffness, vertical", "a rotor without support stiffness has no orbit"},
    {"model", "clearance", "clearance", "clearance_m", "m", 0.3e-3, range::positive,
     "radial clearance delta to the protrusion at the top", "the stator is touched where y exceeds it (Eq. 2); 0 or less is a preload"},
    {"model", "mu", "mu", "mu", "-", 0.24, range::non_negative, "Coulomb friction coefficient f_T = mu f_N", "friction opposes the sliding"},
    {"model", "r", "r", "r", "-", 0.86, range::unit_interval, "coefficient of restitution (restitution variant)",
     "r > 1 would create energy at each impact (Eq. 6)"},
    {"model", "k1", "k1", "k1_N_m", "N/m", 3.946e6, range::positive, "linear contact stiffness", "a contact that pushes back"},
    {"model", "k3", "k3", "k3_N_m3", "N/m^3", 1.408e11, range::non_negative, "cubic contact stiffness", "a softening contact could pull the rotor in"},
    {"model", "c2", "c2", "c2_kg_m", "kg/m", 3.720e4, range::non_negative, "quadratic contact damping (c2 zdot^2)", "negative damping feeds energy in"},

    // A run at constant speed (`simulate`, and each point of the algorithms built on it).
    {"", "rpm", "rpm", "speed_rpm", "rpm", 1600.0, {.lo = 0.0, .hi = 1e6, .lo_open = true}, "shaft speed",
     "the shaft turns forward (docs/model.md, \"Sign conventions\"); above 1e6 rpm no rotor turns, and a run's steps grow with it"},
    {"run", "settle_revs", "settle-revs", "settle_revs", "rev", 200, range::at_least(0), "revolutions from rest discarded before recording", "a count"},
    {"run", "record_revs", "revs", "record_revs", "rev", 20, range::at_least(1), "revolutions recorded", "a record holds at least one revolution"},
    {"", "samples_per_rev", "samples-per-rev", "samples_per_rev", "-", 128, range::at_least(4), "output samples per revolution",
     "fewer cannot show an orbit's shape"},

    // The integration (ref/integrate/steppers.hpp, hybrid_integrator.hpp).
    {"integration", "rtol", "rtol", "rtol", "-", 1e-10, {.lo = 0.0, .hi = 1.0, .lo_open = true, .hi_open = true},
     "relative tolerance of adaptive steppers", "a relative error"},
    {"integration", "atol", "atol", "atol", "m, m/s", 1e-14, range::positive, "absolute tolerance of adaptive steppers", "0 would ask exactness of a zero state"},
    {"integration", "dt", "dt", "dt_s", "s", 0.0, range::non_negative, "rk4 step; 0: period/1024", "a step goes forward in time (0: automatic)"},
    {"integration", "max_dt", "max-dt", "max_dt_s", "s", 0.0, range::non_negative, "largest adaptive step; 0: period/16",
     "a step goes forward in time (0: automatic)"},
    {"integration", "event_tol", "event-tol", "event_time_tolerance_s", "s", 1e-13, range::positive, "event location bracket", "a bracket has a width"},
    {"integration", "stick_time", "stick-time", "stick_time_revs", "rev", 1e-6, {.lo = 0.0, .hi = 1.0, .hi_open = true},
     "restitution: chatter ends in sticking when its remaining impacts fit in this time",
     "a share of one revolution (docs/model.md, \"Chatter\")"},
    {"integration", "max_events_per_rev", "max-events-per-rev", "", "1/rev", 1e3, {.lo = 1.0},
     "events per revolution beyond which an accumulation is an error", "a run with contact has at least one"},
    {"integration", "runaway_displacement", "runaway-displacement", "", "m", 1.0, range::positive,
     "a rotor displaced further than this has diverged (a numerical error)", "a distance"},

    // Shooting for periodic orbits (ref/integrate/shooting.hpp, ref/orbits/periodic_orbit.hpp).
    {"", "tolerance", "tolerance", "tolerance_m", "m", 1e-12, range::positive,
     "Newton's convergence |P(s) - s| (velocities / |w|): 3e-9 of the smallest orbit here (0.33 mm)", "a distance"},
    {"", "periods", "periods", "", "rev", 1, range::count_in(1, 64), "revolutions per period of the orbit (n > 1: subharmonic)",
     "beyond 64 the orbit is not told from a quasi-periodic one by the shooting"},
    {"shooting", "transient_revs", "transient-revs", "", "rev", 40, range::at_least(0), "the second start: revolutions from the first", "a count"},
    {"shooting", "fallback_settle_revs", "fallback-settle-revs", "", "rev", 200, range::at_least(1),
     "the fallback when shooting fails: a transient this long", "the fallback records after a transient"},

    // Periodic orbits as the fits compare them with data (ref/orbits/fit_orbits.hpp).
    {"fit_orbits", "max_iterations", "", "max_iterations", "-", 16, range::count_in(1, 1000),
     "Newton iterations of a fit's shooting at most", "from a neighbouring point's orbit Newton converges in a few; more means the trial model is far off the data"},
    {"fit_orbits", "tolerance_scale", "orbit-tolerance-scale", "orbit_tolerance_scale", "-", 1.0, {.lo = 1e-3, .hi = 1e3},
     "every fit's orbit tolerances (the shooting's |P(s) - s|, the steppers' rtol and atol) times this",
     "a verdict must not depend on them: the loop's stability check (docs/loop.md) reruns at 0.1; below 1e-3 the steppers reach rounding"},
    {"fit_orbits", "max_steps_per_revolution", "", "max_steps_per_revolution", "-", 100000, range::count_in(100, 100000000),
     "integration steps per revolution beyond which a fit's trial model is a failed point",
     "a revolution of the paper's model takes ~1e3 steps; a trial law that needs 100 times more is far off the data"},

    // Continuation (ref/orbits/continuation.hpp): arclength in scaled unknowns, one unit spans the range.
    {"continuation", "from", "from", "", "rpm, m or -", 1300.0, range::any, "start of the parameter's range (its unit)", "a finite value"},
    {"continuation", "to", "to", "", "rpm, m or -", 2200.0, range::any, "end of the parameter's range (its unit), > from", "a finite value"},
    {"continuation", "initial_step", "initial-step", "", "-", 0.01, {.lo = 0.0, .hi = 1.0, .lo_open = true}, "first arclength step",
     "one unit of arclength spans the range"},
    {"continuation", "max_step", "max-step", "", "-", 0.25, {.lo = 0.0, .hi = 1.0, .lo_open = true}, "largest arclength step",
     "one unit of arclength spans the range"},
    {"continuation", "min_step", "min-step", "", "-", 1e-10, {.lo = 0.0, .hi = 1.0, .lo_open = true}, "smallest arclength step before giving up",
     "one unit of arclength spans the range"},
    {"continuation", "max_points", "max-points", "", "-", 5000, range::at_least(2), "points on the branch at most", "a branch has two ends"},

    // Sweeps (ref/sweep/sweep.hpp): speed by speed, each from its neighbour's steady state.
    {"sweep", "from_rpm", "from", "from_rpm", "rpm", 1400.0, {.lo = 0.0, .hi = 1e6, .lo_open = true}, "first speed", "a shaft speed"},
    {"sweep", "to_rpm", "to", "to_rpm", "rpm", 1800.0, {.lo = 0.0, .hi = 1e6, .lo_open = true}, "last speed, >= from_rpm", "a shaft speed"},
    {"sweep", "step_rpm", "step", "step_rpm", "rpm", 5.0, range::positive, "speed step", "a sweep moves"},
    {"sweep", "first_settle_revs", "first-settle-revs", "first_settle_revs", "rev", 200, range::at_least(0),
     "revolutions from rest at the first speed before recording", "a count"},
    {"sweep", "settle_revs", "settle-revs", "settle_revs", "rev", 60, range::at_least(0),
     "revolutions at each later speed, from its neighbour's steady state, before recording", "a count"},
    {"sweep", "record_revs", "revs", "record_revs", "rev", 12, {.lo = 6.0, .integer = true},
     "revolutions recorded per speed, a multiple of 6", "orders 1/2 and 1/3 fall on spectral bins"},

    // The virtual rig (ref/rig/rig.hpp): dwells recorded by probes.
    {"rig", "settle_revs", "settle-revs", "settle_revs", "rev", 100, range::at_least(0),
     "revolutions before each dwell is recorded, from rest or from the previous dwell", "a count"},
    {"rig", "record_revs", "revs", "record_revs", "rev", 16, range::at_least(1), "revolutions recorded per dwell", "a record holds at least one revolution"},
    {"rig", "sample_rate", "sample-rate", "sample_rate_hz", "Hz", 10e3, {.lo = 0.0, .hi = 1e7, .lo_open = true}, "probe sample rate",
     "above 10 MHz is no proximity probe's, and a record's size grows with it"},
    {"rig", "noise", "noise", "noise_m", "m", 0.5e-6, range::non_negative, "probe white noise, standard deviation", "a standard deviation"},
    {"rig", "quantisation", "quantisation", "quantisation_m", "m", 61e-9, range::non_negative, "probe quantisation step (16 bits over +-2 mm)",
     "a step size (0: none)"},

    // The least-squares solver (ref/inference/least_squares.hpp): every fit's defaults; a wing
    // whose fits need others has rows of its own below.
    {"least_squares", "max_jacobians", "", "max_jacobians", "-", 50, range::count_in(1, 10000), "finite-difference Jacobians per fit at most",
     "a fit ends; each Jacobian costs one evaluation per coordinate"},
    {"least_squares", "steps_per_jacobian", "", "steps_per_jacobian", "-", 1, range::count_in(1, 100),
     "accepted steps per finite-difference Jacobian (the others carried by Broyden updates)", "at least the step the Jacobian was taken for"},
    {"least_squares", "difference_step", "", "difference_step", "-", 1e-6, {.lo = 0.0, .hi = 0.1, .lo_open = true},
     "forward-difference step, relative to max(1, |u|) of the scaled coordinate", "a difference quotient needs a step, and one beyond 0.1 is no derivative"},
    {"least_squares", "min_gain", "", "min_gain", "chi^2", 1e-2, range::positive,
     "a step that gains less than this in chi^2 (from a fresh Jacobian) ends the fit",
     "a hundredth of one degree of freedom: far below every decision (a criterion rise of 10)"},
    {"least_squares", "min_gain_share", "", "min_gain_share", "-", 1e-5, range::unit_interval,
     "... or less than this share of chi^2 (a fit far from the noise)", "a share of the sum of squares"},
    {"least_squares", "covariance_lags", "", "covariance_lags", "-", 4, range::count_in(0, 100),
     "lags of the residuals' correlation factor that widens the covariance",
     "resampled or filtered data share samples over a few neighbours; 0: residuals taken as independent"},

    // The evidence rules (ref/inference/evidence.hpp): one set for records, tables and the law's structure.
    {"evidence", "min_documented_level", "", "min_documented_level", "-", 0.1, range::unit_interval,
     "a plausible effect's fitted size, at least this share of the weakest level its library row documents",
     "below a tenth the library calls the effect invisible: a fit that puts it there uses it to absorb something else"},
    {"evidence", "min_criterion_rise", "", "min_criterion_rise", "-", 10.0, range::positive,
     "a part is significant when the information criterion rises by more than this without it; two models within it explain the data alike",
     "Kass & Raftery (1995): a BIC difference above 10 is very strong evidence"},
    {"evidence", "min_excess_share", "", "min_excess_share", "-", 1.0 / 3.0, range::unit_interval,
     "a significant part removes at least this share of the excess over noise that the model without it leaves",
     "a part that removes less explains a detail of a misfit, not the misfit"},
    {"evidence", "min_holdout_share", "", "min_holdout_share", "-", 1.0 / 3.0, range::unit_interval,
     "a needed part gains, on data it was not refitted on, at least this share of its gain on all data",
     "half the data fitted, the other half predicted: a third of the gain is what survives when the part fits the noise of the half it saw"},
    {"evidence", "claim_share", "", "claim_share", "-", 0.96, range::unit_interval,
     "a partial claim: the parts named remove at least this share of the base fit's excess (the residual not noise)",
     "0.96 of the excess energy is a 5-fold cut of its RMS: a model that leaves more than a fifth of the disagreement is no explanation"},
    {"evidence", "max_interval_ratio", "", "max_interval_ratio", "-", 4.0, {.lo = 1.0, .lo_open = true},
     "a positive quantity is determined when its 95 % interval spans less than this end to end", "within a factor of 2 either way"},
    {"evidence", "max_cancellation", "", "max_cancellation", "-", 10.0, {.lo = 1.0},
     "a model whose parts together are more than this many times what they add up to is not plausible",
     "parts that cancel almost exactly explain the data by their small difference, which the data cannot pin"},

    // The loop on records (ref/loop/loop.hpp) and its trace of the residual (ref/loop/trace.hpp).
    {"loop", "mass", "mass", "mass_kg", "kg", 0.0, range::non_negative, "rotor mass; 0: the records' m_kg, else the paper's",
     "a mass (0: taken from the records)"},
    {"loop", "clearance", "clearance", "clearance_m", "m", 0.0, range::non_negative, "clearance for records without clearance_m (0: the records' own)",
     "a distance (0: the records' own)"},
    {"loop", "steps_per_jacobian", "", "steps_per_jacobian", "-", 3, range::count_in(1, 100),
     "accepted steps per finite-difference Jacobian of an orbit fit (the others carried by Broyden updates)",
     "a Jacobian costs an orbit fit one shooting per coordinate and dwell; three steps on one keep its error below the step's gain"},
    {"loop", "check_tolerance_scale", "check-tolerance-scale", "check_tolerance_scale", "-", 0.1, {.lo = 0.0, .hi = 1.0, .hi_open = true},
     "the verdict's check: the whole fit again with every orbit tolerance times this (0: no check); what the two fits do not both name is tentative",
     "a check at the fit's own tolerances or looser tests nothing; 0.1 is the stability check's step (docs/loop.md, \"The verdict's check\")"},
    {"trace", "max_effects", "max-effects", "max_effects", "-", 4, range::count_in(0, 11), "effects added to the model at most",
     "the effect library has 11"},
    {"trace", "refit_candidates", "refit", "refit_candidates", "-", 3, range::count_in(1, 11), "effects refitted per round first (best linearised scores)",
     "at least the best one, at most the library's 11"},
    {"trace", "orders", "", "orders", "-", 20, range::count_in(1, 1000), "shaft orders -H..H of the residual's spectrum and its synchronous test",
     "a contact's harmonics fall below the noise within tens of orders; each order costs a sine per sample"},
    {"trace", "whiteness_lags", "", "whiteness_lags", "-", 20, range::count_in(1, 1000), "lags of the residual's whiteness test (Box-Pierce)",
     "at least one lag"},
    {"trace", "max_jacobians", "", "max_jacobians", "-", 20, range::count_in(1, 10000), "Jacobians per fit of the trace at most",
     "a fit ends; each Jacobian costs one shooting per coordinate and dwell"},
    {"trace", "profile_points", "", "profile_points", "-", 5, range::count_in(2, 101),
     "values at which a shape parameter is profiled across its physical range (ends included)", "a profile has two ends"},

    // The loop on order-tracked tables (ref/tracking/): its fits' solver options and its report.
    {"response_fit", "max_jacobians", "", "max_jacobians", "-", 200, range::count_in(1, 10000), "Jacobians per fit of the closed-form 1X response at most",
     "a fit ends; a closed-form Jacobian costs microseconds, so the budget only stops a fit that creeps along a valley"},
    {"response_fit", "difference_step", "", "difference_step", "-", 1e-6, {.lo = 0.0, .hi = 0.1, .lo_open = true},
     "forward-difference step of the 1X response fit (logarithms of speeds and damping ratios, angles)",
     "a peak 1 % wide needs a step far inside it; the closed form is exact to rounding, so 1e-6 keeps ten digits of the derivative"},
    {"rub_fit", "max_jacobians", "", "max_jacobians", "-", 40, range::count_in(1, 10000), "Jacobians per fit of the rubbing run-up at most",
     "each Jacobian shoots every row's orbit once per coordinate"},
    {"rub_fit", "difference_step", "", "difference_step", "-", 1e-5, {.lo = 0.0, .hi = 0.1, .lo_open = true},
     "forward-difference step of the rub fit", "far above the shot orbits' 1e-12 m, far below the 1 % the table resolves"},
    {"tracking", "residual_bands", "", "residual_bands", "-", 50, range::count_in(1, 1000),
     "stretches of the speed range in which the report locates a residual that is not noise", "at least one stretch"},

    // Identification (ref/identification/identify.hpp), its derivatives, weak form and FROLS.
    {"identify", "mass", "mass", "mass_kg", "kg", 1.52, range::positive, "rotor mass when the linear part is fitted (not identifiable from displacements)",
     "the equations of motion divide by it"},
    {"identify", "clearance", "clearance", "clearance_m", "m", 0.0, range::non_negative, "clearance for records without clearance_m (0: the records' own)",
     "a distance (0: the records' own)"},
    {"identify", "bootstrap", "bootstrap", "bootstrap", "-", 200, range::count_in(0, 100000), "episode-bootstrap resamples for the 95 % intervals (0: none)",
     "a count, bounded so that an identification does not run for hours"},
    {"identify", "seed", "", "seed", "-", 20041122, range::count_in(0, 4294967295.0), "the bootstrap's and the noise perturbations' random seed",
     "an unsigned 32-bit integer"},
    {"identify", "correlation_lags", "", "correlation_lags", "-", 10, range::count_in(1, 1000), "lags of the residual correlation tests",
     "at least one lag"},
    {"derivatives", "half_width", "sg-half-width", "sg_half_width", "samples", 4, range::count_in(1, 1000), "Savitzky-Golay half-width (window 2h + 1)",
     "a window has a centre and a side"},
    {"derivatives", "degree", "sg-degree", "sg_degree", "-", 4, range::count_in(2, 20), "Savitzky-Golay polynomial degree",
     "a second derivative needs degree 2 at least"},
    {"frols", "rho", "rho", "rho", "-", 0.01, {.lo = 0.0, .hi = 1.0, .hi_open = true}, "stop selecting terms when 1 - sum ERR <= rho",
     "a share of the output's variance left (1 would select nothing)"},
    {"frols", "err_threshold", "err-threshold", "err_threshold", "-", 0.01, {.lo = 0.0, .hi = 1.0, .hi_open = true},
     "keep the selected terms whose ERR is at least this", "a share of the output's variance (1 would keep nothing)"},
    {"frols", "err_floor", "", "err_floor", "-", 1e-5, {.lo = 0.0, .hi = 1.0, .lo_open = true, .hi_open = true},
     "significance stop: the least share of y'y a kept term explains", "a share of the output's variance"},
    {"weak_form", "test_functions", "", "test_functions", "-", 6, range::count_in(1, 20), "test functions per contact episode",
     "moments up to s^5 resolve the force pulse's shape; more than 20 only fit the noise"},
    {"weak_form", "bump_power", "", "bump_power", "-", 6, range::count_in(3, 20), "smoothness power of the test functions at the support's ends",
     "Eq. 1's second derivative is moved onto psi by parts: psi, psi' and psi'' must vanish there"},
    {"weak_form", "velocity_half_width", "", "velocity_half_width", "samples", 8, range::count_in(1, 1000),
     "Savitzky-Golay half-width of z_dot, the only derivative the weak form takes", "a window has a centre and a side"},
    {"weak_form", "margin", "", "margin", "-", 0.5, {.lo = 0.0, .hi = 10.0}, "the support's extension beyond each contact episode, a share of its duration",
     "a share of the episode (0: onset and separation on the support's ends)"},

    // Identification's fits by periodic orbits (ref/identification/orbit_fit.hpp) and by output
    // error (ref/identification/output_error.hpp).
    {"orbit_fit", "max_jacobians", "", "max_jacobians", "-", 50, range::count_in(1, 10000), "Jacobians of the orbit fit at most",
     "a fit ends; each Jacobian shoots every cycle's orbit twice per unknown"},
    {"orbit_fit", "phase_search", "", "phase_search", "-", 0, range::count_in(0, 360),
     "phases tried around the circle for each cycle's forcing before the fit (0: the given start)", "at most one per degree"},
    {"reidentify", "max_jacobians", "", "max_jacobians", "-", 50, range::count_in(1, 10000), "Jacobians of the output-error fit at most",
     "a fit ends; each Jacobian simulates every dwell once per parameter"},
    {"reidentify", "global_evaluations", "", "global_evaluations", "-", 600, range::count_in(1, 1000000),
     "simulations of the global stage (DIRECT-L) at most", "the global stage ends"},
    {"reidentify", "derivative_half_width", "", "derivative_half_width", "-", 4, range::count_in(2, 100),
     "Savitzky-Golay half-width of the measured initial states' velocities [samples]", "a derivative of degree 4 needs at least 2 samples each side"},
    {"reidentify", "difference_step", "", "difference_step", "-", 1e-4, {.lo = 0.0, .hi = 0.1, .lo_open = true},
     "forward-difference step of the output-error fit, relative to the parameters' starts",
     "an orbit change far above the integration's 1e-10 relative error, far below the percent the data resolve"},

    // validate's diagnosis (ref/validation/diagnosis.hpp): its one-parameter refits and transforms.
    {"diagnosis", "max_jacobians", "", "max_jacobians", "-", 30, range::count_in(1, 10000),
     "Jacobians of a refit between the grid's neighbours at most", "a refit ends; each Jacobian shoots the hypothesis's orbit once"},
    {"diagnosis", "difference_step", "", "difference_step", "-", 1e-4, {.lo = 0.0, .hi = 0.1, .lo_open = true},
     "forward-difference step of a refit, in units of the grid's spacing",
     "an orbit change far above the shooting's 1e-10 m, far below a grid cell's"},

    // A study's job (ref/study/study.hpp; the SPEC's "job" object, docs/studies.md): what each point
    // runs. Set in the SPEC only: settle_rounds and max_period have no command-line flag.
    {"study", "settle_revs", "settle-revs", "settle_revs", "rev", 60, range::count_in(0, 100000),
     "orbit: revolutions settled before a new shot where one fails or is unstable; simulate: before recording",
     "a count, bounded so that no point of a study runs for hours"},
    {"study", "settle_rounds", "", "settle_rounds", "-", 4, range::count_in(1, 64), "orbit: settle-and-shoot rounds at most",
     "each round settles settle_revs more revolutions: beyond 64 rounds only lengthens a point that does not settle"},
    {"study", "max_period", "", "max_period", "rev", 6, range::count_in(1, 32), "orbit: the longest period looked for",
     "a period is read off the recorded revolutions and shot as an n-revolution map; the shooting itself stops at 64"},
    {"study", "record_revs", "revs", "record_revs", "rev", 12, range::count_in(2, 10000),
     "simulate (and orbit's non-periodic points): revolutions recorded", "a period is recognised when it repeats, so at least two"},
    {"study", "samples_per_rev", "samples-per-rev", "samples_per_rev", "-", 128, range::count_in(8, 100000), "output samples per revolution",
     "a point's summary needs its orbit's shape, and a study's files grow with it"},
});
// clang-format on

// The row of `name` in `scope` (else the shared row): at compile time a name with no row does
// not compile, so every default_of and setting_named below is checked by the compiler.
constexpr const setting_info& setting_named(std::string_view scope, std::string_view name) {
  for (const auto& s : settings_registry)
    if (s.scope == scope && s.name == name) return s;
  for (const auto& s : settings_registry)
    if (s.scope.empty() && s.name == name) return s;
  throw "no such setting in settings_registry";  // not a constant expression: a compile error
}

// The default of a setting, for a struct's member initializer: `double rtol = default_of("integration", "rtol");`.
consteval double default_of(std::string_view scope, std::string_view name) { return setting_named(scope, name).default_value; }
consteval int default_count_of(std::string_view scope, std::string_view name) {
  return static_cast<int>(setting_named(scope, name).default_value);
}

// The range as words ("> 0", ">= 0", "in [0, 1]", "a whole number >= 4", "any real").
std::string describe(const valid_range& r);

// Why `v` is not a valid value of `s` ("`rtol` must be finite and in (0, 1) (got 2): a relative
// error"), or empty if it is. Every value must also be finite. `named_as` replaces the setting's
// `name` at the start (a parameter by its file key: "parameter m_kg").
std::string violation(const setting_info& s, double v, std::string_view named_as = {});

// A row named at compile time: check({"run", "rpm"}, v) does not compile if the registry has no
// such setting.
struct setting_key {
  const setting_info* row;
  consteval setting_key(std::string_view scope, std::string_view name) : row(&setting_named(scope, name)) {}
};

// Throws input_error(violation) unless `v` is valid for the setting.
void check(setting_key key, double v);

// The first row named `name` in any scope, or nullptr: how the command line spells a message's
// `field` (ref/cli/options.cpp). Rows of one name share their flag (tests/settings_test.cpp).
const setting_info* setting_with_name(std::string_view name);

}  // namespace rubref
