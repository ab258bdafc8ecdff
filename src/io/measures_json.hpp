#pragma once
// The fracture measures of issue 21 as summary.json writes them (README, "Outputs"). Every number is
// finite; a value that cannot be formed is null beside a "reason" (or "<key>_reason") saying why, so the
// file stays valid JSON.
#include <nlohmann/json.hpp>

#include "analysis/crack_isotropy.hpp"
#include "analysis/fragments.hpp"

namespace mca::io {

// summary.json's fragment_mass_distribution.
nlohmann::json mass_distribution_json(const analysis::MassDistribution& d);
// summary.json's crack_isotropy.
nlohmann::json crack_isotropy_json(const analysis::CrackIsotropy& c);

}  // namespace mca::io
