#pragma once
// The rows of a merge's site files copied into the merged study
// (study_merge.h says which rows keep their ids and which are numbered anew).

#include <map>
#include <string>
#include <vector>

#include "db/merge_input.h"
#include "db/sqlite_handle.h"
#include "db/study_merge.h"

namespace hapticlab::db::merge {

// Writes the merged study into `out` (a new file of the current schema,
// inside the caller's transaction): the study row of `first`, the settings
// (one name, one set of parameters), the participants, each taken with all
// its rows from `source[code]`, their sessions, training, trials, chunks
// (each verified first), events, loop timing, device counts and operator
// actions. Counts participants, sessions, trials and chunks into `result`
// and its sites (the unskipped ones, in input order). Throws MergeError for
// settings that differ between inputs or a damaged chunk.
void copy_study(std::vector<Input>& inputs, const Input& first, const std::map<std::string, std::size_t>& source,
                Database& out, MergeResult& result);

}  // namespace hapticlab::db::merge
