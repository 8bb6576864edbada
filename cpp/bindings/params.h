// Parameter structs as Python classes. `T()` is the C++ struct as declared, so its defaults are
// stated once, in the header; `T(field=value, ...)` sets the named fields and validates the whole
// struct (T::validate(): ValueError naming the field); fields read and write as attributes. The
// core validates a struct again where it takes it, so a field changed after construction is
// checked too.
#pragma once

#include <algorithm>
#include <string>
#include <utility>
#include <vector>

#include "arrays.h"

namespace moonbot::bindings {

template <typename T>
class ParamsClass {
public:
    ParamsClass(py::handle scope, const char* name, const char* doc) : m_class(scope, name, doc), m_name(name) {
        m_class.def(py::init<>(), "The C++ defaults.");
    }

    /// A number, integer or nested parameter struct field.
    template <typename D>
    ParamsClass& field(const char* name, D T::* member, const char* doc) {
        m_class.def_readwrite(name, member, doc);
        m_fields.emplace_back(name);
        return *this;
    }

    /// A glm::dvec3 field, read as a tuple of 3 floats and written from any length-3 array-like.
    ParamsClass& vec3(const char* name, glm::dvec3 T::* member, const char* doc) {
        const std::string field_name = name;
        m_class.def_property(
            name, [member](const T& t) { return py::make_tuple((t.*member).x, (t.*member).y, (t.*member).z); },
            [member, field_name](T& t, const py::handle& value) { t.*member = vector<3>(value, field_name); }, doc);
        m_fields.emplace_back(name);
        return *this;
    }

    /// A field with its own getter and setter (an enum read and written as its name, a unit
    /// converted).
    template <typename Get, typename Set>
    ParamsClass& property(const char* name, Get&& get, Set&& set, const char* doc) {
        m_class.def_property(name, std::forward<Get>(get), std::forward<Set>(set), doc);
        m_fields.emplace_back(name);
        return *this;
    }

    /// Adds the keyword constructor, validate(), `fields` and __repr__; returns the class for
    /// anything else it binds.
    py::class_<T>& done() {
        const std::vector<std::string> fields = m_fields;
        const std::string name = m_name;
        m_class.def(py::init([fields, name](const py::kwargs& values) {
                        T value;
                        py::object self = py::cast(&value, py::return_value_policy::reference);
                        for (const auto& item : values) {
                            const std::string key = py::str(item.first);
                            if (std::find(fields.begin(), fields.end(), key) == fields.end())
                                throw py::type_error(name + ": no field '" + key + "'");
                            self.attr(key.c_str()) = item.second;
                        }
                        value.validate();  // std::invalid_argument → ValueError
                        return value;
                    }),
                    "The C++ defaults with the fields given set (by name), validated.");
        m_class.def("validate", &T::validate, "Raises ValueError naming the first field out of its range.");
        py::tuple names(fields.size());
        for (size_t i = 0; i < fields.size(); ++i) names[i] = py::str(fields[i]);
        m_class.attr("fields") = names;
        m_class.def("__repr__", [fields, name](const py::object& self) {
            std::string text = name + "(";
            for (size_t i = 0; i < fields.size(); ++i)
                text += (i ? ", " : "") + fields[i] + "=" + std::string(py::repr(self.attr(fields[i].c_str())));
            return text + ")";
        });
        return m_class;
    }

private:
    py::class_<T> m_class;
    std::string m_name;
    std::vector<std::string> m_fields;
};

}  // namespace moonbot::bindings
