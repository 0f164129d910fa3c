#pragma once
// The k-th smallest values of an unsorted sample (order statistics), for
// several k at once, without sorting it: what percentiles_select asks for.
#include <cstddef>
#include <span>
#include <vector>

namespace hapticlab::analysis {

// The values of rank ranks[i] (0-based: rank 0 is the minimum) of `values`,
// exactly the elements a full ascending sort would put at those indices.
// ranks ascending, distinct, each < values.size(); values finite (not
// checked). May reorder `values`.
//
// A large sample of values >= +0 (magnitudes: forces, speeds) is first
// counted by the top 16 bits of each double, which order such values as
// their values do; the counts say which bucket (1/16 of a binade) holds each
// rank, and only those buckets' values are selected among (two passes over
// the sample, in place of nth_element's partitions of all of it). Any other
// sample (a negative value or −0.0 among them, or a small one) is selected
// by nth_element.
std::vector<double> order_statistics(std::vector<double>& values, std::span<const std::size_t> ranks);

}  // namespace hapticlab::analysis
