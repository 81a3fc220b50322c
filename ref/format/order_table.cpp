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
  const auto fail = [&](const std::string& what) -> void { throw input_error(src + ": " + what); };
  const auto meta = [&](std::string_view key) -> std::string {
    const std::string* v = r.find(key);
    return v ? *v : std::string();
  };
  const auto resolve = [&](std::string_view key, const std::string& outside, std::string_view what) {
    declared d;
    const std::string in_file = meta(key);
    if (!in_file.empty() && !outside.empty() && lower(in_file) != lower(outside))
      fail("the " + std::string(what) + " is '" + in_file + "' in the file ('# " + std::string(key) + "') but given as '" + outside + "': say it once");
    if (!in_file.empty()) d = {in_file, "file"};
    else if (!outside.empty()) d = {outside, "given"};
    return d;
  };
  const declared amplitude_kind = resolve("amplitude", given.amplitude, "amplitude convention");
  const declared phase_sense = resolve("phase", given.phase, "phase convention");
  const declared declared_amplitude_unit = resolve("amplitude_unit", given.amplitude_unit, "amplitude unit");
  const declared declared_phase_unit = resolve("phase_unit", given.phase_unit, "phase unit");
  std::optional<double> scale = given.scale_mV_per_um;
  if (const std::string s = meta("scale_mV_per_um"); !s.empty()) {
    const double v = r.number("scale_mV_per_um");
    if (scale && *scale != v) fail("the probe sensitivity is " + s + " mV/um in the file but given as " + format_digits(*scale) + ": say it once");
    scale = v;
  }
  if (scale && !(*scale > 0.0 && std::isfinite(*scale))) fail("the probe sensitivity (scale_mV_per_um) must be a positive number");

  order_table t;
  t.source = src;
  t.metadata = r.metadata;

  // The columns: one speed, amplitude and phase pairs per probe and order, the rest ignored.
  std::size_t speed_column = r.columns.size();
  double speed_factor = 1.0;
  struct pair_columns {
    std::vector<std::size_t> amplitudes, phases;
  };
  std::map<std::pair<std::string, int>, pair_columns> pairs;
  std::vector<std::pair<std::string, int>> pair_order;
  std::vector<std::string> ignored;
  for (std::size_t c = 0; c < r.columns.size(); ++c) {
    const std::string& name = r.columns[c];
    if (is_speed_column(name)) {
      if (speed_column != r.columns.size()) fail("two speed columns ('" + r.columns[speed_column] + "' and '" + name + "'): keep one");
      speed_column = c, speed_factor = name == "speed_hz" ? 60.0 : 1.0;
      continue;
    }
    const auto oc = parse_order_column(name);
    if (!oc) {
      ignored.push_back(name);
      continue;
    }
    const auto key = std::pair{oc->probe, oc->order};
    if (!pairs.count(key)) pair_order.push_back(key);
    (oc->amplitude ? pairs[key].amplitudes : pairs[key].phases).push_back(c);
  }
  if (!ignored.empty()) {
    std::string list;
    for (const auto& n : ignored) list += (list.empty() ? "'" : ", '") + n + "'";
    t.notes.push_back("columns not read (neither the speed nor a [probe_]amp_<k>x / phase_<k>x column): " + list);
  }

  // Conventions every order needs.
  if (amplitude_kind.value.empty())
    fail("the amplitude convention is not declared: give it (" + setting("amplitude") + " 0-peak|pk-pk|rms, or '# amplitude: ...' in the file)");
  const auto kind_factor = to_zero_peak(amplitude_kind.value);
  if (!kind_factor) fail("unknown amplitude convention '" + amplitude_kind.value + "' (0-peak, pk-pk, rms)");
  if (phase_sense.value.empty())
    fail("the phase convention is not declared: give it (" + setting("phase") + " lead if the signal is A cos(k theta + phi), lag if A cos(k theta - phi), theta the shaft "
         "angle after the keyphasor; or '# phase: ...' in the file)");
  const std::string sense = lower(phase_sense.value);
  if (sense != "lead" && sense != "lag") fail("unknown phase convention '" + phase_sense.value + "' (lead, lag)");
  if (!declared_amplitude_unit.value.empty() && !amplitude_unit(declared_amplitude_unit.value))
    fail("unknown amplitude unit '" + declared_amplitude_unit.value + "' (" + std::string(kAmplitudeUnitList) + ")");
  const std::string phase_unit_declared = lower(declared_phase_unit.value);
  if (!phase_unit_declared.empty() && phase_unit_declared != "deg" && phase_unit_declared != "rad")
    fail("unknown phase unit '" + declared_phase_unit.value + "' (deg, rad)");

  // The probes and their angles.
  std::vector<std::string> probes;
  for (const auto& [key, _] : pairs)
    if (std::find(probes.begin(), probes.end(), key.first) == probes.end()) probes.push_back(key.first);
  std::map<std::string, double> angles;  // degrees
  for (const auto& [key, value] : r.metadata) {
    if (key != "probe_angle_deg" && key.rfind("probe_angle_deg.", 0) != 0) continue;
    const std::string probe = key == "probe_angle_deg" ? std::string() : key.substr(16);
    angles[probe] = r.number(key);
  }
  for (const auto& [probe, deg] : given.probe_angles_deg) {
    if (!std::isfinite(deg)) fail("the probe angle of '" + probe + "' is not a finite number");
    if (angles.count(probe) && angles[probe] != deg) fail("the probe angle of '" + probe + "' is in the file and given otherwise: say it once");
    angles[probe] = deg;
  }
  for (const auto& [probe, deg] : angles) {
    const bool known = std::find(probes.begin(), probes.end(), probe) != probes.end() || (probe.empty() && probes.size() == 1);
    if (!known) {
      std::string list;
      for (const auto& p : probes) list += (list.empty() ? "'" : ", '") + p + "'";
      fail(probe.empty() ? "a probe angle without a probe name, but the table has " + std::to_string(probes.size()) + " probes (" + list + "): name it, probe=deg"
                         : "a probe angle for '" + probe + "', which is no probe of this table (" + list + ")" + did_you_mean(probe, probes));
    }
  }

  // The rows, in speed order.
  if (speed_column == r.columns.size()) fail("no speed column");
  const std::size_t n = r.rows();
  std::vector<std::size_t> order(n);
  std::iota(order.begin(), order.end(), 0);
  const auto& speed = r.data[speed_column];
  for (std::size_t i = 0; i < n; ++i)
    if (!(speed[i] > 0.0)) throw input_error(r.where_row(i) + "speed '" + r.columns[speed_column] + "' must be positive");
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return speed[a] < speed[b]; });
  std::size_t drops = 0, rises = 0;
  for (std::size_t i = 1; i < n; ++i) {
    if (speed[i] < speed[i - 1]) ++drops;
    if (speed[i] > speed[i - 1]) ++rises;
  }
  if (drops > 0 && rises == 0) t.notes.push_back("a coast-down (the speed falls through the file): read in rising speed");
  else if (drops > 0)
    t.notes.push_back("rows are not in speed order (the speed falls " + std::to_string(drops) + " times between rows): read in rising speed");
  t.rpm.reserve(n), t.line.reserve(n);
  for (const std::size_t i : order) t.rpm.push_back(speed[i] * speed_factor), t.line.push_back(r.first_data_line + i);
  std::size_t repeats = 0;
  for (std::size_t i = 1; i < n; ++i) repeats += t.rpm[i] == t.rpm[i - 1];
  if (repeats > 0)
    t.notes.push_back(std::to_string(repeats) + " rows repeat another row's speed exactly: each is kept as a measurement of its own");

  // Each probe's orders as complex vectors in metres, 0-to-peak, lead.
  std::string units_used;
  for (const auto& key : pair_order) {
    const pair_columns& pc = pairs[key];
    const std::string label = (key.first.empty() ? "" : key.first + " ") + std::to_string(key.second) + "X";
    if (pc.amplitudes.empty()) fail("no amplitude column for " + label + " (its phase column is '" + r.columns[pc.phases.front()] + "')");
    if (pc.phases.empty()) fail("no phase column for " + label + " (its amplitude column is '" + r.columns[pc.amplitudes.front()] + "')");
    // The amplitude: each column's unit from its suffix, else the declared one; columns without
    // either are not read when another gives the amplitude.
    struct readable {
      std::size_t column;
      std::string unit, from;
    };
    std::vector<readable> amps;
    std::vector<std::string> unread;
    for (const std::size_t c : pc.amplitudes) {
      const std::string suffix = parse_order_column(r.columns[c])->unit;
      if (!suffix.empty()) {
        if (!amplitude_unit(suffix))
          fail("column '" + r.columns[c] + "': unknown amplitude unit '" + suffix + "' (" + std::string(kAmplitudeUnitList) + ")");
        amps.push_back({c, suffix, "column name"});
      } else if (!declared_amplitude_unit.value.empty()) {
        amps.push_back({c, declared_amplitude_unit.value, declared_amplitude_unit.where == "file" ? "file" : "given"});
      } else {
        unread.push_back(r.columns[c]);
      }
    }
    if (amps.empty())
      fail("column '" + unread.front() + "' has no unit: declare it (" + setting("amplitude_unit") + " " + std::string(kAmplitudeUnitList) +
           ", or '# amplitude_unit: ...' in the file)");
    for (const auto& u : unread)
      t.notes.push_back("column '" + u + "' not read: its unit is not declared, and '" + r.columns[amps.front().column] + "' gives the " + label + " amplitude");
    const auto metres_of = [&](const readable& a, std::size_t row) {
      const amplitude_unit_info& u = *amplitude_unit(a.unit);
      const double v = r.data[a.column][row];
      if (u.metres > 0.0) return v * u.metres;
      if (!scale) fail("column '" + r.columns[a.column] + "' is in volts: declare the probe sensitivity (" + setting("scale") + " in mV/um, or '# scale_mV_per_um: ...')");
      return v * u.volts * 1e3 / *scale * 1e-6;
    };
    // The phase: its unit from the suffix, else the declared one.
    const std::size_t phase_col = pc.phases.front();
    std::string phase_unit = lower(parse_order_column(r.columns[phase_col])->unit);
    std::string phase_from = "column name";
    if (phase_unit.empty()) phase_unit = phase_unit_declared, phase_from = declared_phase_unit.where;
    if (phase_unit.empty())
      fail("column '" + r.columns[phase_col] + "' has no unit: declare it (" + setting("phase_unit") + " deg|rad, or '# phase_unit: ...' in the file)");
    if (phase_unit != "deg" && phase_unit != "rad") fail("column '" + r.columns[phase_col] + "': unknown phase unit '" + phase_unit + "' (deg, rad)");
    if (pc.phases.size() > 1) {
      std::string list;
      for (std::size_t i = 1; i < pc.phases.size(); ++i) list += (i > 1 ? ", '" : "'") + r.columns[pc.phases[i]] + "'";
      t.notes.push_back("for " + label + " the phase is read from '" + r.columns[phase_col] + "'; not read: " + list);
    }
    const double to_rad = phase_unit == "deg" ? std::numbers::pi / 180.0 : 1.0;
    const double sign = sense == "lead" ? 1.0 : -1.0;

    tracked_order o;
    o.probe = key.first, o.order = key.second;
    o.amplitude_column = r.columns[amps.front().column], o.phase_column = r.columns[phase_col];
    const auto angle = angles.find(key.first);
    if (angle != angles.end()) o.probe_angle = angle->second * std::numbers::pi / 180.0;
    else if (probes.size() == 1 && angles.count("")) o.probe_angle = angles[""] * std::numbers::pi / 180.0;
    o.vector.reserve(n);
    for (const std::size_t i : order) {
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
      o.vector.push_back(std::polar(a * *kind_factor, sign * r.data[phase_col][i] * to_rad));
    }
    const auto source_of = [](const std::string& from) { return from == "given" ? std::string("given") : "from the " + from; };
    units_used += (units_used.empty() ? "" : "; ") + label + ": '" + o.amplitude_column + "' in " + amps.front().unit + " (" + source_of(amps.front().from) +
                  "), '" + o.phase_column + "' in " + phase_unit + " (" + source_of(phase_from) + ")";
    t.orders.push_back(std::move(o));
  }
  t.conventions = "amplitude " + amplitude_kind.value + " (" + (amplitude_kind.where == "file" ? "from the file" : "given") + "), phase " + sense + " (" +
                  (phase_sense.where == "file" ? "from the file" : "given") + "); " + units_used;

  // Dwells: the longest run of rows, in file order, within 1 % of its first row's speed. Said, so
  // a reader knows where the table's weight lies; the fit takes every row as one measurement.
  std::size_t best_from = 0, best_length = 0;
  for (std::size_t i = 0; i < n && best_length < n - i; ++i) {
    std::size_t j = i + 1;
    while (j < n && std::abs(speed[j] - speed[i]) <= 0.01 * speed[i]) ++j;
    if (j - i > best_length) best_from = i, best_length = j - i;
  }
  if (best_length >= 10 && best_length * 10 >= n) {
    double lo = speed[best_from], hi = lo;
    for (std::size_t i = best_from; i < best_from + best_length; ++i) lo = std::min(lo, speed[i]), hi = std::max(hi, speed[i]);
    t.notes.push_back("lines " + std::to_string(r.first_data_line + best_from) + "-" + std::to_string(r.first_data_line + best_from + best_length - 1) + ": " +
                      std::to_string(best_length) + " rows (" + format_fixed(100.0 * static_cast<double>(best_length) / static_cast<double>(n), 0) +
                      " % of the table) dwell at " + format_fixed(speed_factor * lo, 0) + "-" + format_fixed(speed_factor * hi, 0) +
                      " rpm; each is one measurement, and where the amplitude is near the noise its phase scatters");
  }
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
  for (const auto& o : t.orders) {
    const std::string stem = (o.probe.empty() ? "" : o.probe + "_");
    const std::string k = std::to_string(o.order) + "x";
    out += "," + stem + "amp_" + k + (style.unit_suffixes ? "_" + style.amplitude_unit : "") + "," + stem + "phase_" + k + (style.unit_suffixes ? "_" + phase_unit : "");
  }
  out += "\n";
  for (std::size_t i = 0; i < t.rows(); ++i) {
    out += format_number(t.rpm[i]);
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
