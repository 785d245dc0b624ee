// Python values -> the scene's vectors: numpy arrays (or sequences) in the order of the scene's
// names, or dicts keyed by those names. Every problem raises ValueError naming the argument and the
// index or name (a wrong shape, a NaN or infinity, an unknown name, a value that is not a number).
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <Eigen/Core>
#include <string>
#include <vector>

namespace coopdyn::py {

namespace pyb = pybind11;

// One state vector. obj: None (out keeps its default), a 1-D array-like of names.size() numbers, or
// a dict {name: number} (the names it leaves out keep out's default). arg names the argument in
// messages ("q", "tau", ...), order the scene's attribute that lists names ("q_names").
void read_vector(pyb::handle obj, const char* arg, const std::vector<std::string>& names, const char* order,
                 Eigen::VectorXd& out);

// A stack of states: None (rows = every row of def), or an (N, names.size()) array-like; N is checked
// against *rows (set when negative). The result is C-contiguous float64, its numbers all finite.
pyb::array_t<double> read_stack(pyb::handle obj, const char* arg, const std::vector<std::string>& names,
                                const char* order, const Eigen::VectorXd& def, long* rows);

// The index of name in names, else ValueError "arg: unknown WHAT 'name'HINT".
int index_of(const std::vector<std::string>& names, const std::string& name, const char* arg, const char* what,
             const char* hint = "");

}  // namespace coopdyn::py
