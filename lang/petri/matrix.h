// A small dense integer matrix for the incidence matrices B-, B+ and B of a P/T net
// (spec petri-sfc.md, "Petri net definitions used": rows = places, columns =
// transitions) and for the module composition B = sum_k B^_ik / D.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace rtplc::petri {

class IntMatrix {
 public:
  IntMatrix() = default;
  IntMatrix(size_t rows, size_t cols) : rows_(rows), cols_(cols), v_(rows * cols, 0) {}
  // Row-major literal, for tests and small hand-written nets.
  static IntMatrix from_rows(const std::vector<std::vector<int64_t>>& rows);

  size_t rows() const { return rows_; }
  size_t cols() const { return cols_; }
  int64_t& operator()(size_t r, size_t c) { return v_[r * cols_ + c]; }
  int64_t operator()(size_t r, size_t c) const { return v_[r * cols_ + c]; }
  bool operator==(const IntMatrix& o) const = default;

  size_t nonzero_count() const;
  // Aligned text with optional row and column labels (empty vectors: indices).
  std::string to_string(const std::vector<std::string>& row_labels = {},
                        const std::vector<std::string>& col_labels = {}) const;

 private:
  size_t rows_ = 0;
  size_t cols_ = 0;
  std::vector<int64_t> v_;
};

}  // namespace rtplc::petri
