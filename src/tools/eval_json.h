// tescalib_eval's JSON (the evaluation contract, doc/evaluation.md): the document is
// built with nlohmann-json and written in the contract's layout.
#pragma once

#include <ostream>

#include <nlohmann/json.hpp>

namespace tescalib::eval {

/// Keys keep the order they are added in (the contract's order).
using Json = nlohmann::ordered_json;

/// A number, or null when it is not finite: a value that does not exist (a baseline's covariance,
/// an extrinsic the mode does not estimate) is null, never 0 (which would read as exact).
Json jsonNumber(double v);
/// n numbers, each as jsonNumber.
Json jsonArray(const double* v, int n);

/// Writes `j` on one line with ", " and ": " between items and numbers to 10 significant digits,
/// except that each object of an array of objects (the trials) has a line of its own.
void writeJson(std::ostream& out, const Json& j);

}  // namespace tescalib::eval
