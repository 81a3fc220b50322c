#pragma once
// Numbers as text, written once for the whole library: files use the shortest round-trip form,
// messages and reports a fixed number of significant digits or decimals.

#include <string>

namespace rubref {

// The shortest decimal that reads back to exactly v (records, tables, parameter files).
std::string format_number(double v);
// Exactly 17 significant digits (golden files: the precision is visible in every cell).
std::string format_number_17(double v);
// `digits` significant digits, for messages and reports (as printf's %g; 17 reads back exactly).
std::string format_digits(double v, int digits = 4);
// `decimals` digits after the point (as printf's %.*f), for reports' tables and file names.
std::string format_fixed(double v, int decimals);

}  // namespace rubref
