#pragma once
// A measurement record as constant-speed dwells (docs/data-format.md): the speed column is
// constant within a dwell and changes between dwells; samples are uniform within a dwell.

#include <limits>
#include <string>
#include <vector>

#include "ref/format/record.hpp"

namespace rubref {

struct dwell {
  double rpm = 0.0;
  double dt = 0.0;                // s, uniform sample spacing
  std::vector<double> t, x, y;    // s, m, m
  std::vector<double> keyphasor;  // 1 at the first sample after the shaft's notch (empty: no such column)
  // s, the uncertainty of t's shaft angle once re-based on the keyphasor (align_by_keyphasor);
  // infinity: times as recorded (shaft-synchronous by docs/data-format.md, which identify tests)
  double timing_sigma = std::numeric_limits<double>::infinity();
  double clearance = 0.0;         // m, from the record's clearance_m metadata (0: not stated)
  bool periodic = false;          // the samples are one revolution of a periodic orbit (averaged)
  std::string source;             // "file.csv, lines a-b" for messages

  double omega() const;           // rad/s
  std::size_t size() const { return t.size(); }
};

// Synchronous (order-tracked) averaging of a steady dwell: its whole revolutions are resampled
// onto `round(T / dt)` phase points (cubic interpolation when T / dt is not an integer) and
// averaged, which divides white noise by sqrt(revolutions). The result is one revolution,
// `periodic` = true, times starting at the dwell's first sample. Meaningful only for orbits that
// repeat every revolution; `spread` reports the RMS deviation of the revolutions from their mean.
struct averaged_dwell {
  dwell cycle;
  int revolutions = 0;
  double spread = 0.0;  // m
};
averaged_dwell synchronous_average(const dwell& d);

// Probe noise (m) from the data: 4th differences remove a sampled orbit (its 4th difference at
// 10 kHz is ~1e-10 m) and leave white noise with variance 70 sigma^2; their median absolute value
// over x and y of every dwell, scaled for Gaussian noise, ignores impacts. 0 without samples.
double estimate_probe_noise(const std::vector<const dwell*>& dwells);

// The resolution of a probe's samples (m): the smallest step between distinct values when every
// value lies on that grid (an ADC's step, a file's last digit); 0 when they do not (or when fewer
// than two distinct values leave no step to see).
double quantisation_step(const std::vector<double>& v);

// One dwell's noise (m). Rounding to a step q is noise of q / sqrt(12) that no filter and no
// average removes (revolutions that repeat round alike). Where the white noise is below it, the
// 4th differences of an orbit that moves less than a step per sample read ~0 (of one that moves
// many steps, ~1.2 q / sqrt(12), the uniform rounding read by a Gaussian-scaled median): the
// dwell's noise is the larger of the two.
struct dwell_noise {
  double sigma = 0.0;         // m, max(white, quantisation / sqrt(12))
  double white = 0.0;         // m, the 4th-difference estimate on this dwell alone
  double quantisation = 0.0;  // m, the larger of x's and y's steps (0: not on a grid)
};
dwell_noise estimate_dwell_noise(const dwell& d);

// Re-bases a dwell's times on its keyphasor (t = 0 at a notch passage), so that w t is the shaft
// angle from the notch in every dwell, whatever clock the record was taken on; returns the timing
// uncertainty (s; infinity without a keyphasor column or pulse, times then as recorded) and notes
// what it cannot do.
double align_by_keyphasor(dwell& d, std::vector<std::string>& notes);

// Displacements are in metres (docs/data-format.md). A radial proximity probe reads a few
// millimetres at most (the common 8 mm probe's linear range is 2 mm), a rig's shaft rubs a stator
// well under a millimetre away, and the paper's rotor with no stator at all peaks at about 1 mm
// at its critical speed: an |x| or |y| of a centimetre is no rotor's, but millimetres (or micrometres) in
// columns that say metres. A fit to it would return numbers, all nonsense, so identify, the loop
// and the order tracker refuse it. The same bound as the clearance's unit warning (parameter_io.hpp).
inline constexpr double kImplausibleDisplacement = 0.01;  // m

// input_error "<source>:<line>: x_m reaches 0.35 m, ...; if the file holds millimetres, divide
// x_m and y_m by 1000" when |x_m| or |y_m| reaches kImplausibleDisplacement.
void check_displacement_scale(const record& r, const std::string& source);

// Splits every record into its dwells. input_error (naming the file and line) if its
// displacements are not metres (check_displacement_scale), a dwell is shorter than
// `min_samples`, its sampling is not uniform, or its speed is not positive.
std::vector<dwell> split_dwells(const record& r, const std::string& source, std::size_t min_samples = 16);

}  // namespace rubref
