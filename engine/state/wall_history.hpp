#pragma once
/// The contact law's history of the particle-wall rows: per wall, one row of `width` values per
/// candidate particle - row r of wall k belongs to particle wall_candidates[k][r] - with that
/// particle's id, so a row follows its particle through a rebuild's sort, a deletion or a new
/// candidate list. Only the particles within reach of a wall carry a row: a per-particle field
/// per wall held 7 columns x 3 walls x 17,876 particles (3.0 MB, nearly all zeros) in the main
/// scenario's hot press (issue 63).
#include <algorithm>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "engine/core/archive.hpp"
#include "engine/core/error.hpp"
#include "engine/core/types.hpp"

namespace sparkdem {

struct WallHistory {
  int width = 0;                          ///< values per row: the law's state columns (0: a law without state)
  std::vector<std::vector<Id>> ids;       ///< per wall: the particle of each row
  std::vector<std::vector<double>> rows;  ///< per wall: `width` values per row

  /// Fresh history of w columns for `walls` walls: no rows (follow gives each candidate a zero row).
  void reset(int w, std::size_t walls) {
    width = w;
    ids.assign(walls, {});
    rows.assign(walls, {});
  }
  /// True when wall k's rows are those of its candidate list `cand` (one per candidate).
  bool aligned(std::size_t k, const std::vector<Index>& cand) const {
    return width == 0 || (k < ids.size() && ids[k].size() == cand.size() && rows[k].size() == cand.size() * static_cast<std::size_t>(width));
  }
  /// The rows of the new candidate lists `cand` (local indices, `id` the particles' ids): a
  /// candidate keeps the row its particle had, a new one starts at zero. A particle that is no
  /// longer a candidate loses its row: it is beyond r + skin of the wall, and no longer touched it
  /// when it was last a candidate (it could not leave reach within the skin's half without a pass
  /// seeing it apart from the wall, and that pass cleared its history).
  void follow(const std::vector<std::vector<Index>>& cand, const std::vector<Id>& id) {
    if (width == 0) return;
    ids.resize(cand.size());
    rows.resize(cand.size());
    const std::size_t w = static_cast<std::size_t>(width);
    for (std::size_t k = 0; k < cand.size(); ++k) {
      std::vector<std::pair<Id, std::size_t>> old(ids[k].size());
      for (std::size_t r = 0; r < old.size(); ++r) old[r] = {ids[k][r], r};
      std::sort(old.begin(), old.end());
      std::vector<Id> new_ids(cand[k].size());
      std::vector<double> new_rows(cand[k].size() * w, 0.0);
      for (std::size_t r = 0; r < cand[k].size(); ++r) {
        new_ids[r] = id[static_cast<std::size_t>(cand[k][r])];
        const auto it = std::lower_bound(old.begin(), old.end(), std::pair<Id, std::size_t>{new_ids[r], 0});
        if (it != old.end() && it->first == new_ids[r]) std::copy_n(rows[k].begin() + static_cast<std::ptrdiff_t>(it->second * w), w, new_rows.begin() + static_cast<std::ptrdiff_t>(r * w));
      }
      ids[k] = std::move(new_ids);
      rows[k] = std::move(new_rows);
    }
  }
  /// Stored under state/wall_history (absent while there is none); `names` the walls' names.
  void visit(Archive& ar, const std::vector<std::string>& names) {
    std::int64_t w = width;
    if (!ar.reading() || ar.has("state/wall_history/width")) ar.visit("state/wall_history/width", w);
    else w = 0;
    if (ar.reading()) {
      if (w < 0 || w > 1000) throw SetupError("checkpoint wall history width " + std::to_string(w) + ": expected 0 to 1000");
      reset(static_cast<int>(w), w > 0 ? names.size() : 0);
    }
    if (w == 0) return;
    for (std::size_t k = 0; k < names.size(); ++k) {
      ar.visit("state/wall_history/" + names[k] + "/ids", ids[k]);
      ar.visit("state/wall_history/" + names[k] + "/rows", rows[k], width);
      if (ar.reading() && rows[k].size() != ids[k].size() * static_cast<std::size_t>(width))
        throw SetupError("checkpoint wall history of '" + names[k] + "' holds " + std::to_string(rows[k].size()) + " values for " +
                         std::to_string(ids[k].size()) + " rows of " + std::to_string(width));
    }
  }
};

}  // namespace sparkdem
