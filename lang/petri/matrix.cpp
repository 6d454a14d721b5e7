// Dense integer matrices for B-, B+, B and module composition (spec petri-sfc.md).
#include "lang/petri/matrix.h"

#include <algorithm>

namespace rtplc::petri {

IntMatrix IntMatrix::from_rows(const std::vector<std::vector<int64_t>>& rows) {
  const size_t cols = rows.empty() ? 0 : rows.front().size();
  IntMatrix m(rows.size(), cols);
  for (size_t r = 0; r < rows.size(); ++r) {
    for (size_t c = 0; c < cols && c < rows[r].size(); ++c) m(r, c) = rows[r][c];
  }
  return m;
}

size_t IntMatrix::nonzero_count() const {
  return static_cast<size_t>(std::count_if(v_.begin(), v_.end(), [](int64_t x) { return x != 0; }));
}

std::string IntMatrix::to_string(const std::vector<std::string>& row_labels,
                                 const std::vector<std::string>& col_labels) const {
  auto row_name = [&](size_t r) {
    return r < row_labels.size() ? row_labels[r] : std::to_string(r);
  };
  auto col_name = [&](size_t c) {
    return c < col_labels.size() ? col_labels[c] : std::to_string(c);
  };
  size_t label_w = 0;
  for (size_t r = 0; r < rows_; ++r) label_w = std::max(label_w, row_name(r).size());
  std::vector<size_t> w(cols_, 1);
  for (size_t c = 0; c < cols_; ++c) {
    w[c] = std::max(w[c], col_name(c).size());
    for (size_t r = 0; r < rows_; ++r) w[c] = std::max(w[c], std::to_string((*this)(r, c)).size());
  }
  auto pad = [](const std::string& s, size_t width) {
    return std::string(width > s.size() ? width - s.size() : 0, ' ') + s;
  };
  std::string out = std::string(label_w, ' ');
  for (size_t c = 0; c < cols_; ++c) out += ' ' + pad(col_name(c), w[c]);
  out += '\n';
  for (size_t r = 0; r < rows_; ++r) {
    std::string name = row_name(r);
    out += name + std::string(label_w - name.size(), ' ');
    for (size_t c = 0; c < cols_; ++c) out += ' ' + pad(std::to_string((*this)(r, c)), w[c]);
    out += '\n';
  }
  return out;
}

}  // namespace rtplc::petri
