#pragma once
// Order-tracked tables (docs/data-format.md, "Order-tracked tables"): what a rig or a plant's
// monitoring system exports from a run-up or coast-down, one row per tracked revolution block,
// with the shaft speed and, per probe and shaft order, an amplitude and a phase. The file's
// conventions (amplitude unit and kind, phase sense and unit, probe angles) come from its
// metadata or the command line; anything the reader cannot know is an error naming what to
// declare, never a default.
//
// Inside rubref every tracked order becomes one complex vector per row, in metres and 0-to-peak,
// with the probe's reading  s(theta) = Re(v e^{j k theta}),  theta the shaft angle after the
// keyphasor pulse, turning with the rotation (docs/model.md's sense).

#include <complex>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace rubref {

inline constexpr std::string_view kOrderTableFormat = "rubref-order-table 1";

// What the file does not say, given from outside (the command line, Python). Each field empty or
// unset: not given here. Given both here and in the file, the two must agree.
struct order_conventions {
  std::string amplitude_unit;  // m, mm, um, mil, V, mV (the amplitude columns without a unit suffix)
  std::string amplitude;       // 0-peak, pk-pk, rms
  std::string phase;           // lead: s = A cos(k theta + phi); lag: s = A cos(k theta - phi)
  std::string phase_unit;      // deg, rad (the phase columns without a unit suffix)
  std::optional<double> scale_mV_per_um;  // a volt amplitude's probe sensitivity
  // Probe angles in degrees from the model's +x axis towards +y (the rotation sense); the name ""
  // is the table's only probe. A probe without an angle has it fitted (one probe) or is refused.
  std::vector<std::pair<std::string, double>> probe_angles_deg;
};

// One probe's one order through the table.
struct tracked_order {
  std::string probe;                         // "" when the table has one probe and names none
  int order = 1;                             // shaft order k (1 for 1X)
  std::optional<double> probe_angle;         // rad from +x towards +y; unset: not declared
  std::vector<std::complex<double>> vector;  // m, 0-to-peak, per row: s = Re(v e^{j k theta})
  std::string amplitude_column, phase_column;
};

struct order_table {
  std::string source;
  std::vector<std::pair<std::string, std::string>> metadata;
  std::vector<double> rpm;               // per row, rising (the reader sorts)
  std::vector<std::size_t> line;         // the file line of each row (tracked from a record: its dwell's place in time); its order is the sweep's
  std::vector<double> time_s;            // per row, the time of its block's middle (a time_s column; empty: the table has none)
  std::vector<bool> dwell;               // per row, whether it is in the table's dwell (the notes say it; empty: none)
  std::vector<tracked_order> orders;     // in header order
  std::vector<std::string> notes;        // what the reader did and found: order, repeats, dwells, ignored columns
  std::string conventions;               // one line: the conventions used and where each came from

  std::size_t rows() const { return rpm.size(); }
};

// Whether a header names an order-tracked table (a speed column and amplitude columns, no t_s):
// how `rubref loop` tells a table from a time record.
bool is_order_table_header(const std::vector<std::string>& columns);
// The header of the file at `path` (after its metadata), for that test; input_error if unreadable.
std::vector<std::string> header_of(const std::filesystem::path& path);

// How a table is written (to_csv): the conventions a monitoring system might export in.
struct order_table_style {
  std::string amplitude = "0-peak";  // 0-peak, pk-pk, rms
  std::string phase = "lead";        // lead, lag
  std::string amplitude_unit = "um"; // m, mm, um, mil, V, mV (V and mV need scale_mV_per_um)
  std::string phase_unit = "deg";    // deg, rad
  double scale_mV_per_um = 0.0;
  bool declare = true;               // conventions and probe angles as metadata (else they must be given to the reader)
  bool unit_suffixes = true;         // units in the column names (else as metadata when declared)
};
// input_error on an unknown convention or a volt unit without a scale.
std::string to_csv(const order_table& t, const order_table_style& style);

// input_error "<source>:<line>: <problem>" on anything malformed or ambiguous; writes nothing.
order_table parse_order_table(std::string_view text, std::string_view source, const order_conventions& given);
order_table read_order_table(const std::filesystem::path& path, const order_conventions& given);

}  // namespace rubref
