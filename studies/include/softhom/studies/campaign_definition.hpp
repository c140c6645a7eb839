#pragma once
// The declared keys of a campaign file (campaign.hpp describes the layout), for `softhom keys sweep`
// and docs/keys.md. Axis values, [base] and the named definitions are RVE scene tables, declared by
// the RVE scene parser.
#include "softhom/core/keys.hpp"

namespace softhom::studies {

std::vector<keys::TableDoc> campaign_tables();

}  // namespace softhom::studies
