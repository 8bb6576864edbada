// Argument checks at the Python boundary: every array argument is converted and checked here,
// with the GIL held, so the core only ever sees C-contiguous buffers of the right type and shape.
// Failures raise ValueError naming the argument.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstdint>
#include <string>
#include <vector>

#include <glm/glm.hpp>

namespace moonbot::bindings {

namespace py = pybind11;

[[noreturn]] inline void fail(const std::string& name, const std::string& what) {
    throw py::value_error(name + ": " + what);
}

/// Any array-like as a numpy array (lists are welcome; objects, strings and ragged input are not).
inline py::array as_array(const py::handle& obj, const std::string& name) {
    py::array a = py::array::ensure(obj);
    if (!a) fail(name, "must be an array-like of numbers");
    const char kind = a.dtype().kind();
    if (kind != 'f' && kind != 'i' && kind != 'u' && kind != 'b')
        fail(name, "must hold numbers, got dtype " + std::string(py::str(a.dtype())));
    return a;
}

/// `a` converted to a C-contiguous array of T. A conversion numpy refuses (an overflow under
/// `np.seterr(all="raise")` or warnings-as-errors, say) is a ValueError naming the argument,
/// never a null array.
template <typename T>
py::array_t<T, py::array::c_style> converted(const py::array& a, const std::string& name) {
    auto c = py::array_t<T, py::array::c_style | py::array::forcecast>::ensure(a);
    if (!c) {
        PyErr_Clear();
        fail(name, "cannot be converted to " + std::string(py::str(py::dtype::of<T>())) +
                       " (out of range, or refused by numpy)");
    }
    return c;
}

/// A path for the C++ side: a NUL character would silently cut it short there.
inline const std::string& checked_path(const std::string& path) {
    if (path.find('\0') != std::string::npos) fail("path", "contains a NUL character");
    if (path.empty()) fail("path", "is empty");
    return path;
}

inline std::string shape_of(const py::array& a) {
    std::string s = "(";
    for (py::ssize_t i = 0; i < a.ndim(); ++i) s += (i ? ", " : "") + std::to_string(a.shape(i));
    return s + (a.ndim() == 1 ? ",)" : ")");
}

/// An N×cols array of floating-point values, as C-contiguous float32 (float64 input is narrowed).
inline py::array_t<float, py::array::c_style> float_rows(const py::handle& obj, const std::string& name, int cols) {
    py::array a = as_array(obj, name);
    if (a.dtype().kind() != 'f')
        fail(name, "must be a floating-point array, got dtype " + std::string(py::str(a.dtype())));
    if (a.ndim() != 2 || a.shape(1) != cols)
        fail(name, "must have shape (N, " + std::to_string(cols) + "), got " + shape_of(a));
    return converted<float>(a, name);
}

/// An N×3 array of integer indices, as C-contiguous uint32; negative or ≥ 2³² values rejected.
inline std::vector<uint32_t> index_rows(const py::handle& obj, const std::string& name) {
    py::array a = as_array(obj, name);
    const char kind = a.dtype().kind();
    if (kind != 'i' && kind != 'u')
        fail(name, "must be an integer array, got dtype " + std::string(py::str(a.dtype())));
    if (a.ndim() != 2 || a.shape(1) != 3) fail(name, "must have shape (M, 3), got " + shape_of(a));
    // uint64 values ≥ 2⁶³ wrap to negative int64 here, which the range check below rejects.
    auto wide = converted<int64_t>(a, name);
    std::vector<uint32_t> out(static_cast<size_t>(wide.size()));
    const int64_t* p = wide.data();
    for (size_t i = 0; i < out.size(); ++i) {
        if (p[i] < 0 || p[i] > 0xFFFFFFFFll) fail(name, "index " + std::to_string(p[i]) + " is negative or too large");
        out[i] = static_cast<uint32_t>(p[i]);
    }
    return out;
}

/// A finite rows×cols float64 matrix, row-major, as a glm column-major matrix.
template <int R, int C>
glm::mat<C, R, double> matrix(const py::handle& obj, const std::string& name) {
    py::array a = as_array(obj, name);
    if (a.ndim() != 2 || a.shape(0) != R || a.shape(1) != C)
        fail(name, "must have shape (" + std::to_string(R) + ", " + std::to_string(C) + "), got " + shape_of(a));
    auto d = converted<double>(a, name);
    glm::mat<C, R, double> m;
    for (int r = 0; r < R; ++r)
        for (int c = 0; c < C; ++c) m[c][r] = d.at(r, c);
    return m;
}

/// A length-n float64 vector.
template <int N>
glm::vec<N, double> vector(const py::handle& obj, const std::string& name) {
    py::array a = as_array(obj, name);
    if (a.ndim() != 1 || a.shape(0) != N)
        fail(name, "must have shape (" + std::to_string(N) + ",), got " + shape_of(a));
    auto d = converted<double>(a, name);
    glm::vec<N, double> v;
    for (int i = 0; i < N; ++i) v[i] = d.at(i);
    return v;
}

}  // namespace moonbot::bindings
