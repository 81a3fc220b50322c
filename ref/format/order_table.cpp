#include "ref/format/order_table.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <map>
#include <numbers>
#include <numeric>

#include "ref/base/errors.hpp"
#include "ref/base/number_text.hpp"
#include "ref/format/record.hpp"

namespace rubref {

namespace {

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

std::vector<std::string> split(std::string_view s, char sep) {
  std::vector<std::string> out;
  std::size_t pos = 0;
  while (true) {
    const std::size_t next = std::min(s.find(sep, pos), s.size());
    out.emplace_back(s.substr(pos, next - pos));
    if (next == s.size()) return out;
    pos = next + 1;
  }
}

// A column `[probe_]amp_<k>x[_unit]` or `[probe_]phase_<k>x[_unit]`, k a shaft order up to this
// (order tracking of a rotor kit goes to a few orders; a monitoring system's to tens).
constexpr int kMaxOrder = 100;
struct order_column {
  bool amplitude = false;
  std::string probe, unit;
  int order = 0;
};

std::optional<order_column> parse_order_column(std::string_view name) {
  const std::vector<std::string> tokens = split(name, '_');
  for (std::size_t i = 0; i + 1 < tokens.size(); ++i) {
    const std::string word = lower(tokens[i]), next = lower(tokens[i + 1]);
    if (word != "amp" && word != "amplitude" && word != "phase") continue;
    if (next.size() < 2 || next.back() != 'x' || !std::all_of(next.begin(), next.end() - 1, [](char c) { return std::isdigit(static_cast<unsigned char>(c)); }))
      continue;
    order_column c;
    c.amplitude = word != "phase";
    // Shaft orders 1..kMaxOrder; more digits than an int holds (the fuzzer's "amp_99999999999x")
    // or order 0 make it no order column.
    const auto [end, ec] = std::from_chars(next.data(), next.data() + next.size() - 1, c.order);
    if (ec != std::errc() || end != next.data() + next.size() - 1 || c.order < 1 || c.order > kMaxOrder) return std::nullopt;
    for (std::size_t j = 0; j < i; ++j) c.probe += (j ? "_" : "") + tokens[j];
    for (std::size_t j = i + 2; j < tokens.size(); ++j) c.unit += (j > i + 2 ? "_" : "") + tokens[j];
    return c;
  }
  return std::nullopt;
}

bool is_speed_column(std::string_view name) { return name == "rpm" || name == "speed_rpm" || name == "speed_hz"; }

// Metres per unit of a displacement amplitude; nullopt for volts (which need the sensitivity).
struct amplitude_unit_info {
  std::string_view name;
  double metres;  // 0 for volts
  double volts;
};
constexpr amplitude_unit_info kAmplitudeUnits[] = {
    {"m", 1.0, 0.0}, {"mm", 1e-3, 0.0}, {"um", 1e-6, 0.0}, {"mil", 25.4e-6, 0.0}, {"v", 0.0, 1.0}, {"mv", 0.0, 1e-3}};
constexpr std::string_view kAmplitudeUnitList = "m, mm, um, mil, V, mV";

const amplitude_unit_info* amplitude_unit(std::string_view unit) {
  const std::string u = lower(unit);
  for (const auto& a : kAmplitudeUnits)
    if (a.name == u || (u == "mils" && a.name == "mil") || (u == "micron" && a.name == "um")) return &a;
  return nullptr;
}

// The amplitude convention's factor to 0-to-peak.
std::optional<double> to_zero_peak(std::string_view kind) {
  const std::string k = lower(kind);
  if (k == "0-peak" || k == "0-pk" || k == "zero-peak" || k == "0-to-peak" || k == "peak") return 1.0;
  if (k == "pk-pk" || k == "peak-peak" || k == "peak-to-peak" || k == "p-p" || k == "pp") return 0.5;
  if (k == "rms") return std::numbers::sqrt2;
  return std::nullopt;
}

// A convention declared in the file, given from outside, or both (then they must agree).
struct declared {
  std::string value, where;  // where: "file", "given"; empty value: not declared
};

[[noreturn]] void fail(const std::string& source, const std::string& what) { throw input_error(source + ": " + what); }

// The conventions as declared: in the file's metadata, given from outside, or both (they must agree).
struct declared_conventions {
  declared amplitude_kind, phase_sense, amplitude_unit, phase_unit;
  std::optional<double> scale;  // mV/um
};

declared_conventions conventions_declared(const record& r, const std::string& src, const order_conventions& given) {
  const auto meta = [&](std::string_view key) -> std::string {
    const std::string* v = r.find(key);
    return v ? *v : std::string();
  };
  const auto resolve = [&](std::string_view key, const std::string& outside, std::string_view what) {
    declared d;
    const std::string in_file = meta(key);
    if (!in_file.empty() && !outside.empty() && lower(in_file) != lower(outside))
      fail(src, "the " + std::string(what) + " is '" + in_file + "' in the file ('# " + std::string(key) + "') but given as '" + outside + "': say it once");
    if (!in_file.empty()) d = {in_file, "file"};
    else if (!outside.empty()) d = {outside, "given"};
    return d;
  };
  declared_conventions out;
  out.amplitude_kind = resolve("amplitude", given.amplitude, "amplitude convention");
  out.phase_sense = resolve("phase", given.phase, "phase convention");
  out.amplitude_unit = resolve("amplitude_unit", given.amplitude_unit, "amplitude unit");
  out.phase_unit = resolve("phase_unit", given.phase_unit, "phase unit");
  out.scale = given.scale_mV_per_um;
  if (const std::string s = meta("scale_mV_per_um"); !s.empty()) {
    const double v = r.number("scale_mV_per_um");
    if (out.scale && *out.scale != v) fail(src, "the probe sensitivity is " + s + " mV/um in the file but given as " + format_digits(*out.scale) + ": say it once");
    out.scale = v;
  }
  if (out.scale && !(*out.scale > 0.0 && std::isfinite(*out.scale))) fail(src, "the probe sensitivity (scale_mV_per_um) must be a positive number");
  return out;
}

// An order's amplitude and phase columns.
struct pair_columns {
  std::vector<std::size_t> amplitudes, phases;
};

// The columns: one speed, amplitude and phase pairs per probe and order, the rest ignored.
struct table_columns {
  std::size_t speed;  // the column count if there is none
  double speed_factor = 1.0;  // to rpm
  std::optional<std::size_t> time;  // a time_s column: each row's time (the sweep's, docs/data-format.md)
  std::map<std::pair<std::string, int>, pair_columns> pairs;
  std::vector<std::pair<std::string, int>> pair_order;  // in header order
  std::vector<std::string> ignored;
};

table_columns columns_of(const record& r, const std::string& src) {
  table_columns out;
  out.speed = r.columns.size();
  for (std::size_t c = 0; c < r.columns.size(); ++c) {
    const std::string& name = r.columns[c];
    if (is_speed_column(name)) {
      if (out.speed != r.columns.size()) fail(src, "two speed columns ('" + r.columns[out.speed] + "' and '" + name + "'): keep one");
      out.speed = c, out.speed_factor = name == "speed_hz" ? 60.0 : 1.0;
      continue;
    }
    if (name == "time_s") {  // (a column named twice is the record reader's error)
      out.time = c;
      continue;
    }
    const auto oc = parse_order_column(name);
    if (!oc) {
      out.ignored.push_back(name);
      continue;
    }
    const auto key = std::pair{oc->probe, oc->order};
    if (!out.pairs.count(key)) out.pair_order.push_back(key);
    (oc->amplitude ? out.pairs[key].amplitudes : out.pairs[key].phases).push_back(c);
  }
  return out;
}

// The conventions every order needs, known and understood.
struct table_reading {
  double kind_factor;               // to 0-to-peak
  std::string sense;                // lead, lag
  std::string phase_unit_declared;  // deg, rad, or "" (each phase column's suffix then)
};

table_reading check_conventions(const declared_conventions& d, const std::string& src) {
  if (d.amplitude_kind.value.empty())
    fail(src, "the amplitude convention is not declared: give it (" + setting("amplitude") + " 0-peak|pk-pk|rms, or '# amplitude: ...' in the file)");
  const auto kind_factor = to_zero_peak(d.amplitude_kind.value);
  if (!kind_factor) fail(src, "unknown amplitude convention '" + d.amplitude_kind.value + "' (0-peak, pk-pk, rms)");
  if (d.phase_sense.value.empty())
    fail(src, "the phase convention is not declared: give it (" + setting("phase") + " lead if the signal is A cos(k theta + phi), lag if A cos(k theta - phi), theta the shaft "
              "angle after the keyphasor; or '# phase: ...' in the file)");
  const std::string sense = lower(d.phase_sense.value);
  if (sense != "lead" && sense != "lag") fail(src, "unknown phase convention '" + d.phase_sense.value + "' (lead, lag)");
  if (!d.amplitude_unit.value.empty() && !amplitude_unit(d.amplitude_unit.value))
    fail(src, "unknown amplitude unit '" + d.amplitude_unit.value + "' (" + std::string(kAmplitudeUnitList) + ")");
  const std::string phase_unit_declared = lower(d.phase_unit.value);
  if (!phase_unit_declared.empty() && phase_unit_declared != "deg" && phase_unit_declared != "rad")
    fail(src, "unknown phase unit '" + d.phase_unit.value + "' (deg, rad)");
  return {*kind_factor, sense, phase_unit_declared};
}

// The probes and their angles.
struct probe_angles {
  std::vector<std::string> probes;
  std::map<std::string, double> degrees;  // "" for the table's only probe
};

probe_angles probes_of(const record& r, const table_columns& columns, const order_conventions& given, const std::string& src) {
  probe_angles out;
  for (const auto& [key, _] : columns.pairs)
    if (std::find(out.probes.begin(), out.probes.end(), key.first) == out.probes.end()) out.probes.push_back(key.first);
  auto& angles = out.degrees;
  for (const auto& [key, value] : r.metadata) {
    if (key != "probe_angle_deg" && key.rfind("probe_angle_deg.", 0) != 0) continue;
    const std::string probe = key == "probe_angle_deg" ? std::string() : key.substr(16);
    angles[probe] = r.number(key);
  }
  for (const auto& [probe, deg] : given.probe_angles_deg) {
    if (!std::isfinite(deg)) fail(src, "the probe angle of '" + probe + "' is not a finite number");
    if (angles.count(probe) && angles[probe] != deg) fail(src, "the probe angle of '" + probe + "' is in the file and given otherwise: say it once");
    angles[probe] = deg;
  }
  for (const auto& [probe, deg] : angles) {
    const bool known = std::find(out.probes.begin(), out.probes.end(), probe) != out.probes.end() || (probe.empty() && out.probes.size() == 1);
    if (!known) {
      std::string list;
      for (const auto& p : out.probes) list += (list.empty() ? "'" : ", '") + p + "'";
      fail(src, probe.empty() ? "a probe angle without a probe name, but the table has " + std::to_string(out.probes.size()) + " probes (" + list + "): name it, probe=deg"
                              : "a probe angle for '" + probe + "', which is no probe of this table (" + list + ")" + did_you_mean(probe, out.probes));
    }
  }
  return out;
}

// The rows in rising speed, and what their order says.
struct speed_rows {
  std::vector<std::size_t> order;  // row indices, in rising speed
  std::vector<double> rpm;
  std::vector<std::size_t> line;
  std::vector<std::string> notes;
};

speed_rows rows_by_speed(const record& r, const table_columns& columns, const std::string& src) {
  if (columns.speed == r.columns.size()) fail(src, "no speed column");
  const std::size_t n = r.rows();
  speed_rows out;
  out.order.resize(n);
  std::iota(out.order.begin(), out.order.end(), 0);
  const auto& speed = r.data[columns.speed];
  for (std::size_t i = 0; i < n; ++i)
    if (!(speed[i] > 0.0)) throw input_error(r.where_row(i) + "speed '" + r.columns[columns.speed] + "' must be positive");
  std::stable_sort(out.order.begin(), out.order.end(), [&](std::size_t a, std::size_t b) { return speed[a] < speed[b]; });
  std::size_t drops = 0, rises = 0;
  for (std::size_t i = 1; i < n; ++i) {
    if (speed[i] < speed[i - 1]) ++drops;
    if (speed[i] > speed[i - 1]) ++rises;
  }
  if (drops > 0 && rises == 0) out.notes.push_back("a coast-down (the speed falls through the file): read in rising speed");
  else if (drops > 0)
    out.notes.push_back("rows are not in speed order (the speed falls " + std::to_string(drops) + " times between rows): read in rising speed");
  out.rpm.reserve(n), out.line.reserve(n);
  for (const std::size_t i : out.order) out.rpm.push_back(speed[i] * columns.speed_factor), out.line.push_back(r.first_data_line + i);
  std::size_t repeats = 0;
  for (std::size_t i = 1; i < n; ++i) repeats += out.rpm[i] == out.rpm[i - 1];
  if (repeats > 0)
    out.notes.push_back(std::to_string(repeats) + " rows repeat another row's speed exactly: each is kept as a measurement of its own");
  return out;
}

// An amplitude column that can be read, with its unit and where the unit came from.
struct readable_amplitude {
  std::size_t column;
  std::string unit, from;
};

// The amplitude columns read, and notes on those that are not.
struct amplitude_reading {
  std::vector<readable_amplitude> columns;  // the first gives the amplitude, the others check it
  std::vector<std::string> notes;
};

// The amplitude: each column's unit from its suffix, else the declared one; columns without
// either are not read when another gives the amplitude.
amplitude_reading amplitude_columns(const record& r, const pair_columns& pc, const declared& declared_unit, const std::string& label,
                                    const std::string& src) {
  amplitude_reading out;
  std::vector<readable_amplitude>& amps = out.columns;
  std::vector<std::string> unread;
  for (const std::size_t c : pc.amplitudes) {
    const std::string suffix = parse_order_column(r.columns[c])->unit;
    if (!suffix.empty()) {
      if (!amplitude_unit(suffix))
        fail(src, "column '" + r.columns[c] + "': unknown amplitude unit '" + suffix + "' (" + std::string(kAmplitudeUnitList) + ")");
      amps.push_back({c, suffix, "column name"});
    } else if (!declared_unit.value.empty()) {
      amps.push_back({c, declared_unit.value, declared_unit.where == "file" ? "file" : "given"});
    } else {
      unread.push_back(r.columns[c]);
    }
  }
  if (amps.empty())
    fail(src, "column '" + unread.front() + "' has no unit: declare it (" + setting("amplitude_unit") + " " + std::string(kAmplitudeUnitList) +
              ", or '# amplitude_unit: ...' in the file)");
  for (const auto& u : unread)
    out.notes.push_back("column '" + u + "' not read: its unit is not declared, and '" + r.columns[amps.front().column] + "' gives the " + label + " amplitude");
  return out;
}

// One probe's order as complex vectors in metres, 0-to-peak, lead, with what was read and noted.
struct read_order {
  tracked_order order;
  std::string units;  // the columns' units and their sources, for order_table::conventions
  std::vector<std::string> notes;
};

read_order order_of(const record& r, const std::pair<std::string, int>& key, const pair_columns& pc, const declared_conventions& conventions,
                    const table_reading& reading, const probe_angles& probes, const speed_rows& rows, const std::string& src) {
  read_order out;
  const std::string label = (key.first.empty() ? "" : key.first + " ") + std::to_string(key.second) + "X";
  if (pc.amplitudes.empty()) fail(src, "no amplitude column for " + label + " (its phase column is '" + r.columns[pc.phases.front()] + "')");
  if (pc.phases.empty()) fail(src, "no phase column for " + label + " (its amplitude column is '" + r.columns[pc.amplitudes.front()] + "')");
  amplitude_reading amplitude = amplitude_columns(r, pc, conventions.amplitude_unit, label, src);
  out.notes = std::move(amplitude.notes);
  const std::vector<readable_amplitude>& amps = amplitude.columns;
  const auto metres_of = [&](const readable_amplitude& a, std::size_t row) {
    const amplitude_unit_info& u = *amplitude_unit(a.unit);
    const double v = r.data[a.column][row];
    if (u.metres > 0.0) return v * u.metres;
    if (!conventions.scale)
      fail(src, "column '" + r.columns[a.column] + "' is in volts: declare the probe sensitivity (" + setting("scale") + " in mV/um, or '# scale_mV_per_um: ...')");
    return v * u.volts * 1e3 / *conventions.scale * 1e-6;
  };
  // The phase: its unit from the suffix, else the declared one.
  const std::size_t phase_col = pc.phases.front();
  std::string phase_unit = lower(parse_order_column(r.columns[phase_col])->unit);
  std::string phase_from = "column name";
  if (phase_unit.empty()) phase_unit = reading.phase_unit_declared, phase_from = conventions.phase_unit.where;
  if (phase_unit.empty())
    fail(src, "column '" + r.columns[phase_col] + "' has no unit: declare it (" + setting("phase_unit") + " deg|rad, or '# phase_unit: ...' in the file)");
  if (phase_unit != "deg" && phase_unit != "rad") fail(src, "column '" + r.columns[phase_col] + "': unknown phase unit '" + phase_unit + "' (deg, rad)");
  if (pc.phases.size() > 1) {
    std::string list;
    for (std::size_t i = 1; i < pc.phases.size(); ++i) list += (i > 1 ? ", '" : "'") + r.columns[pc.phases[i]] + "'";
    out.notes.push_back("for " + label + " the phase is read from '" + r.columns[phase_col] + "'; not read: " + list);
  }
  const double to_rad = phase_unit == "deg" ? std::numbers::pi / 180.0 : 1.0;
  const double sign = reading.sense == "lead" ? 1.0 : -1.0;

  tracked_order& o = out.order;
  o.probe = key.first, o.order = key.second;
  o.amplitude_column = r.columns[amps.front().column], o.phase_column = r.columns[phase_col];
  const auto angle = probes.degrees.find(key.first);
  if (angle != probes.degrees.end()) o.probe_angle = angle->second * std::numbers::pi / 180.0;
  else if (probes.probes.size() == 1 && probes.degrees.count("")) o.probe_angle = probes.degrees.at("") * std::numbers::pi / 180.0;
  o.vector.reserve(rows.order.size());
  for (const std::size_t i : rows.order) {
    const double a = metres_of(amps.front(), i);
    if (a < 0.0)
      throw input_error(r.where_row(i) + "column '" + r.columns[amps.front().column] + "': a negative amplitude (write a sign into the phase)");
    // Two amplitude columns with units must say the same (a wrong declared unit shows here).
    for (std::size_t k = 1; k < amps.size(); ++k) {
      const double b = metres_of(amps[k], i);
      if (std::abs(a - b) > 1e-6 * std::max(std::abs(a), std::abs(b)) + 1e-15)
        throw input_error(r.where_row(i) + "columns '" + r.columns[amps.front().column] + "' (" + amps.front().unit + ", from the " + amps.front().from + ") and '" +
                          r.columns[amps[k].column] + "' (" + amps[k].unit + ", from the " + amps[k].from + ") disagree: " + format_digits(a) + " m and " +
                          format_digits(b) + " m; is the declared unit right?");
    }
    o.vector.push_back(std::polar(a * reading.kind_factor, sign * r.data[phase_col][i] * to_rad));
  }
  const auto source_of = [](const std::string& from) { return from == "given" ? std::string("given") : "from the " + from; };
  out.units = label + ": '" + o.amplitude_column + "' in " + amps.front().unit + " (" + source_of(amps.front().from) + "), '" + o.phase_column + "' in " +
              phase_unit + " (" + source_of(phase_from) + ")";
  return out;
}

// Dwells: the longest run of rows, in file order, within 1 % of its first row's speed, where it
// holds at least 10 rows and a tenth of the table (data rows from..from+length).
struct dwell_run {
  std::size_t from = 0, length = 0;
};
std::optional<dwell_run> longest_dwell(const record& r, const table_columns& columns) {
  const auto& speed = r.data[columns.speed];
  const std::size_t n = r.rows();
  std::size_t best_from = 0, best_length = 0;
  for (std::size_t i = 0; i < n && best_length < n - i; ++i) {
    std::size_t j = i + 1;
    while (j < n && std::abs(speed[j] - speed[i]) <= 0.01 * speed[i]) ++j;
    if (j - i > best_length) best_from = i, best_length = j - i;
  }
  if (!(best_length >= 10 && best_length * 10 >= n)) return std::nullopt;
  return dwell_run{best_from, best_length};
}

// A dwell, said, so a reader knows where the table's weight lies; the fit takes every row as one
// measurement.
std::optional<std::string> dwell_note(const record& r, const table_columns& columns) {
  const auto& speed = r.data[columns.speed];
  const auto dwell = longest_dwell(r, columns);
  if (!dwell) return std::nullopt;
  const std::size_t n = r.rows(), best_from = dwell->from, best_length = dwell->length;
  double lo = speed[best_from], hi = lo;
  for (std::size_t i = best_from; i < best_from + best_length; ++i) lo = std::min(lo, speed[i]), hi = std::max(hi, speed[i]);
  return "lines " + std::to_string(r.first_data_line + best_from) + "-" + std::to_string(r.first_data_line + best_from + best_length - 1) + ": " +
         std::to_string(best_length) + " rows (" + format_fixed(100.0 * static_cast<double>(best_length) / static_cast<double>(n), 0) +
         " % of the table) dwell at " + format_fixed(columns.speed_factor * lo, 0) + "-" + format_fixed(columns.speed_factor * hi, 0) +
         " rpm; each is one measurement, and where the amplitude is near the noise its phase scatters";
}

}  // namespace

bool is_order_table_header(const std::vector<std::string>& columns) {
  if (std::find(columns.begin(), columns.end(), "t_s") != columns.end()) return false;
  const bool speed = std::any_of(columns.begin(), columns.end(), [](const std::string& c) { return is_speed_column(c); });
  const bool amplitude = std::any_of(columns.begin(), columns.end(), [](const std::string& c) {
    const auto oc = parse_order_column(c);
    return oc && oc->amplitude;
  });
  return speed && amplitude;
}

std::vector<std::string> header_of(const std::filesystem::path& path) {
  const std::string text = read_text_file(path);
  std::size_t pos = 0;
  while (pos < text.size()) {
    const std::size_t end = std::min(text.find('\n', pos), text.size());
    std::string line = text.substr(pos, end - pos);
    pos = end + 1;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line.front() == '#') continue;
    std::vector<std::string> columns;
    for (auto& c : split(line, ',')) {
      const auto first = c.find_first_not_of(" \t"), last = c.find_last_not_of(" \t");
      columns.push_back(first == std::string::npos ? "" : c.substr(first, last - first + 1));
    }
    return columns;
  }
  return {};
}

order_table parse_order_table(std::string_view text, std::string_view source, const order_conventions& given) {
  const record r = parse_numeric_table(text, source, kOrderTableFormat, "rpm,amp_1x_um,phase_1x_deg,...", [](const std::vector<std::string>& columns) {
    if (!is_order_table_header(columns))
      return std::string("an order-tracked table needs a speed column (rpm, speed_rpm or speed_hz) and amplitude columns ([probe_]amp_<k>x[_unit])");
    return std::string();
  });
  const std::string src(source);
  const declared_conventions conventions = conventions_declared(r, src, given);
  order_table t;
  t.source = src;
  t.metadata = r.metadata;

  const table_columns columns = columns_of(r, src);
  if (!columns.ignored.empty()) {
    std::string list;
    for (const auto& n : columns.ignored) list += (list.empty() ? "'" : ", '") + n + "'";
    t.notes.push_back("columns not read (neither the speed, time_s nor a [probe_]amp_<k>x / phase_<k>x column): " + list);
  }
  const table_reading reading = check_conventions(conventions, src);
  const probe_angles probes = probes_of(r, columns, given, src);
  const speed_rows rows = rows_by_speed(r, columns, src);
  t.rpm = rows.rpm, t.line = rows.line;
  if (columns.time) {
    // Each row's time, in the rows' (rising speed) order; two rows at one time cannot both be
    // blocks of one sweep.
    const auto& time = r.data[*columns.time];
    for (const std::size_t i : rows.order) t.time_s.push_back(time[i]);
    std::vector<double> sorted = t.time_s;
    std::sort(sorted.begin(), sorted.end());
    if (const auto twice = std::adjacent_find(sorted.begin(), sorted.end()); twice != sorted.end())
      fail(src, "two rows have the same time_s (" + format_number(*twice) + " s): a row is one block of the sweep, at its own time");
  }
  t.notes.insert(t.notes.end(), rows.notes.begin(), rows.notes.end());

  std::string units_used;
  for (const auto& key : columns.pair_order) {
    read_order o = order_of(r, key, columns.pairs.at(key), conventions, reading, probes, rows, src);
    t.notes.insert(t.notes.end(), o.notes.begin(), o.notes.end());
    units_used += (units_used.empty() ? "" : "; ") + o.units;
    t.orders.push_back(std::move(o.order));
  }
  t.conventions = "amplitude " + conventions.amplitude_kind.value + " (" + (conventions.amplitude_kind.where == "file" ? "from the file" : "given") +
                  "), phase " + reading.sense + " (" + (conventions.phase_sense.where == "file" ? "from the file" : "given") + "); " + units_used;
  if (auto note = dwell_note(r, columns)) t.notes.push_back(std::move(*note));
  if (const auto dwell = longest_dwell(r, columns))
    for (const std::size_t i : rows.order) t.dwell.push_back(i >= dwell->from && i < dwell->from + dwell->length);
  return t;
}

std::string to_csv(const order_table& t, const order_table_style& style) {
  const auto kind = to_zero_peak(style.amplitude);
  if (!kind) throw input_error("unknown amplitude convention '" + style.amplitude + "' (0-peak, pk-pk, rms)");
  const std::string sense = lower(style.phase), phase_unit = lower(style.phase_unit);
  if (sense != "lead" && sense != "lag") throw input_error("unknown phase convention '" + style.phase + "' (lead, lag)");
  if (phase_unit != "deg" && phase_unit != "rad") throw input_error("unknown phase unit '" + style.phase_unit + "' (deg, rad)");
  const amplitude_unit_info* unit = amplitude_unit(style.amplitude_unit);
  if (!unit) throw input_error("unknown amplitude unit '" + style.amplitude_unit + "' (" + std::string(kAmplitudeUnitList) + ")");
  if (unit->metres == 0.0 && !(style.scale_mV_per_um > 0.0)) throw input_error("a volt amplitude needs the probes' sensitivity (scale_mV_per_um)");
  std::string out = "# format: " + std::string(kOrderTableFormat) + "\n";
  if (style.declare) {
    out += "# amplitude: " + style.amplitude + "\n# phase: " + sense + "\n";
    if (!style.unit_suffixes) out += "# amplitude_unit: " + style.amplitude_unit + "\n# phase_unit: " + phase_unit + "\n";
    for (const auto& o : t.orders)
      if (o.probe_angle && o.order == 1)
        out += "# probe_angle_deg" + (o.probe.empty() ? std::string() : "." + o.probe) + ": " + format_number(*o.probe_angle * 180.0 / std::numbers::pi) + "\n";
  }
  if (unit->metres == 0.0) out += "# scale_mV_per_um: " + format_number(style.scale_mV_per_um) + "\n";
  out += "rpm";
  if (!t.time_s.empty()) out += ",time_s";
  for (const auto& o : t.orders) {
    const std::string stem = (o.probe.empty() ? "" : o.probe + "_");
    const std::string k = std::to_string(o.order) + "x";
    out += "," + stem + "amp_" + k + (style.unit_suffixes ? "_" + style.amplitude_unit : "") + "," + stem + "phase_" + k + (style.unit_suffixes ? "_" + phase_unit : "");
  }
  out += "\n";
  for (std::size_t i = 0; i < t.rows(); ++i) {
    out += format_number(t.rpm[i]);
    if (!t.time_s.empty()) out += "," + format_number(t.time_s[i]);
    for (const auto& o : t.orders) {
      const double metres = std::abs(o.vector[i]) / *kind;
      const double amplitude = unit->metres > 0.0 ? metres / unit->metres : metres * 1e6 * style.scale_mV_per_um * 1e-3 / unit->volts;
      const double phase = (sense == "lead" ? 1.0 : -1.0) * std::arg(o.vector[i]) * (phase_unit == "deg" ? 180.0 / std::numbers::pi : 1.0);
      out += "," + format_number(amplitude) + "," + format_number(phase);
    }
    out += "\n";
  }
  return out;
}

order_table read_order_table(const std::filesystem::path& path, const order_conventions& given) {
  return parse_order_table(read_text_file(path), path.string(), given);
}

}  // namespace rubref
