#include "protocols/design.h"

#include <algorithm>
#include <numeric>
#include <stdexcept>
#include <tuple>

#include "protocols/rng.h"

namespace hapticlab::protocols {
namespace {

// Smallest possible sum of squares of `cells` non-negative integers adding
// up to `total`: as even as possible, q or q+1 each.
long long min_sum_of_squares(long long total, long long cells) {
  if (cells == 0) return 0;
  const long long q = total / cells;
  const long long r = total % cells;
  return cells * q * q + r * (2 * q + 1);
}

// The search state: the subsets plus running item and pair counts, so a move
// is scored in O(k + m²) instead of recounting everything.
class Search {
 public:
  Search(std::vector<std::vector<std::size_t>> subsets, std::size_t m)
      : subsets_(std::move(subsets)), m_(m), items_(m, 0), pairs_(m * m, 0) {
    for (const auto& s : subsets_) add(s, +1);
  }

  // Lexicographic objective; smaller is better.
  using Key = std::tuple<int, long long, int, long long>;

  Key key() const {
    int imin = 0, imax = 0;
    long long isq = 0;
    for (std::size_t a = 0; a < m_; ++a) {
      const int c = items_[a];
      if (a == 0 || c < imin) imin = c;
      if (a == 0 || c > imax) imax = c;
      isq += static_cast<long long>(c) * c;
    }
    int pmin = 0, pmax = 0;
    long long psq = 0;
    bool first = true;
    for (std::size_t a = 0; a < m_; ++a) {
      for (std::size_t b = a + 1; b < m_; ++b) {
        const int c = pairs_[a * m_ + b];
        if (first || c < pmin) pmin = c;
        if (first || c > pmax) pmax = c;
        first = false;
        psq += static_cast<long long>(c) * c;
      }
    }
    return {imax - imin, isq, pmax - pmin, psq};
  }

  // Replace item `out` of subset p by `in` (not in it).
  void replace(std::size_t p, std::size_t out, std::size_t in) {
    auto& s = subsets_[p];
    add(s, -1);
    *std::find(s.begin(), s.end(), out) = in;
    add(s, +1);
  }

  bool contains(std::size_t p, std::size_t item) const {
    const auto& s = subsets_[p];
    return std::find(s.begin(), s.end(), item) != s.end();
  }

  // One pass of first-improvement moves over participants in random order.
  // Returns whether anything improved.
  bool improve_once(Rng& rng) {
    const std::size_t n = subsets_.size();
    std::vector<std::size_t> order(n);
    std::iota(order.begin(), order.end(), 0);
    shuffle(order, rng);
    bool improved = false;
    Key best = key();
    for (std::size_t p : order) {
      // Move 1: swap one item of p for one outside it.
      for (std::size_t i = 0; i < subsets_[p].size(); ++i) {
        for (std::size_t in = 0; in < m_; ++in) {
          const std::size_t out = subsets_[p][i];
          if (contains(p, in)) continue;
          replace(p, out, in);
          const Key k = key();
          if (k < best) {
            best = k;
            improved = true;
          } else {
            replace(p, in, out);
          }
        }
      }
      // Move 2: exchange an item with another participant (item counts stay).
      for (std::size_t q : order) {
        if (q == p) continue;
        for (std::size_t i = 0; i < subsets_[p].size(); ++i) {
          for (std::size_t j = 0; j < subsets_[q].size(); ++j) {
            const std::size_t a = subsets_[p][i];
            const std::size_t b = subsets_[q][j];
            if (contains(p, b) || contains(q, a)) continue;
            replace(p, a, b);
            replace(q, b, a);
            const Key k = key();
            if (k < best) {
              best = k;
              improved = true;
            } else {
              replace(q, a, b);
              replace(p, b, a);
            }
          }
        }
      }
    }
    return improved;
  }

  std::vector<std::vector<std::size_t>> sorted_subsets() const {
    auto out = subsets_;
    for (auto& s : out) std::sort(s.begin(), s.end());
    return out;
  }

 private:
  void add(const std::vector<std::size_t>& s, int delta) {
    for (std::size_t i = 0; i < s.size(); ++i) {
      items_[s[i]] += delta;
      for (std::size_t j = i + 1; j < s.size(); ++j) {
        pairs_[s[i] * m_ + s[j]] += delta;
        pairs_[s[j] * m_ + s[i]] += delta;
      }
    }
  }

  std::vector<std::vector<std::size_t>> subsets_;
  std::size_t m_;
  std::vector<int> items_;
  std::vector<int> pairs_;  // m×m, symmetric
};

}  // namespace

DesignBalance design_balance(const std::vector<std::vector<std::size_t>>& subsets, std::size_t m) {
  DesignBalance b;
  b.item_counts.assign(m, 0);
  b.pair_counts.assign(m, std::vector<int>(m, 0));
  for (const auto& s : subsets) {
    for (std::size_t i = 0; i < s.size(); ++i) {
      if (s[i] >= m) throw std::invalid_argument("design_balance(): item index >= m");
      ++b.item_counts[s[i]];
      for (std::size_t j = i + 1; j < s.size(); ++j) {
        ++b.pair_counts[s[i]][s[j]];
        ++b.pair_counts[s[j]][s[i]];
      }
    }
  }
  if (m > 0) {
    const auto [lo, hi] = std::minmax_element(b.item_counts.begin(), b.item_counts.end());
    b.item_spread = *hi - *lo;
  }
  if (m > 1) {
    int lo = b.pair_counts[0][1], hi = lo;
    for (std::size_t a = 0; a < m; ++a) {
      for (std::size_t c = a + 1; c < m; ++c) {
        lo = std::min(lo, b.pair_counts[a][c]);
        hi = std::max(hi, b.pair_counts[a][c]);
      }
    }
    b.pair_spread = hi - lo;
  }
  return b;
}

int ideal_item_spread(std::size_t n, std::size_t m, std::size_t k) {
  return m == 0 || (n * k) % m == 0 ? 0 : 1;
}

int ideal_pair_spread(std::size_t n, std::size_t m, std::size_t k) {
  const std::size_t pairs = m * (m - (m > 0 ? 1 : 0)) / 2;
  return pairs == 0 || (n * (k * (k - (k > 0 ? 1 : 0)) / 2)) % pairs == 0 ? 0 : 1;
}

std::vector<std::vector<std::size_t>> balanced_subsets(std::size_t n, std::size_t m, std::size_t k,
                                                       std::uint64_t seed) {
  if (k > m) throw std::invalid_argument("balanced_subsets(): k must be <= m");
  if (k == 0 || k == m || n == 0) {
    std::vector<std::size_t> all(k);
    std::iota(all.begin(), all.end(), 0);
    return std::vector<std::vector<std::size_t>>(n, all);
  }

  // The best any design could do: used to stop the search early.
  const long long pair_cells = static_cast<long long>(m * (m - 1) / 2);
  const long long pairs_per_subset = static_cast<long long>(k * (k - 1) / 2);
  const Search::Key ideal{ideal_item_spread(n, m, k),
                          min_sum_of_squares(static_cast<long long>(n * k), static_cast<long long>(m)),
                          ideal_pair_spread(n, m, k),
                          min_sum_of_squares(static_cast<long long>(n) * pairs_per_subset, pair_cells)};

  constexpr int kStarts = 64;
  Rng rng(seed);
  std::vector<std::vector<std::size_t>> best;
  Search::Key best_key{};
  for (int start = 0; start < kStarts; ++start) {
    // Start: round robin over a shuffled item order, which already gives
    // item counts within 1 of each other (k <= m keeps each subset distinct).
    std::vector<std::size_t> items(m);
    std::iota(items.begin(), items.end(), 0);
    shuffle(items, rng);
    std::vector<std::vector<std::size_t>> subsets(n);
    for (std::size_t p = 0; p < n; ++p) {
      for (std::size_t j = 0; j < k; ++j) subsets[p].push_back(items[(p * k + j) % m]);
    }
    shuffle(subsets, rng);

    Search search(std::move(subsets), m);
    while (search.improve_once(rng)) {
    }
    const Search::Key key = search.key();
    if (best.empty() || key < best_key) {
      best = search.sorted_subsets();
      best_key = key;
    }
    if (best_key <= ideal) break;
  }
  return best;
}

std::vector<std::vector<std::size_t>> assign_settings(const Protocol& protocol) {
  const std::size_t n = protocol.participants.size();
  std::vector<std::size_t> all(protocol.settings.size());
  std::iota(all.begin(), all.end(), 0);
  std::vector<std::vector<std::size_t>> out;

  switch (protocol.design.type) {
    case DesignType::kComplete:
      out.assign(n, all);
      break;
    case DesignType::kIncomplete: {
      // Split the protocol's settings into required and optional, keeping
      // protocol order within each.
      std::vector<std::size_t> required, optional;
      for (std::size_t i : all) {
        const auto& name = protocol.settings[i].settings.name;
        const auto& req = protocol.design.required;
        (std::find(req.begin(), req.end(), name) != req.end() ? required : optional).push_back(i);
      }
      Rng stream = Rng::for_stream(protocol.seed, "design");
      const auto subsets =
          balanced_subsets(n, optional.size(), static_cast<std::size_t>(protocol.design.k), stream.next());
      for (const auto& s : subsets) {
        std::vector<std::size_t> mine = required;
        for (std::size_t o : s) mine.push_back(optional[o]);
        std::sort(mine.begin(), mine.end());
        out.push_back(std::move(mine));
      }
      break;
    }
    case DesignType::kExplicit:
      for (const auto& ps : protocol.participants) {
        std::vector<std::size_t> mine;
        for (const auto& name : protocol.design.assignments.at(ps.code)) mine.push_back(*protocol.find_setting(name));
        std::sort(mine.begin(), mine.end());
        out.push_back(std::move(mine));
      }
      break;
  }
  return out;
}

}  // namespace hapticlab::protocols
