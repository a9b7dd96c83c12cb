// The oracle registry: one explicit table from lowercase name to factory
// (Tungsten's IntegratorFactory; no static self-registration, which a linker
// may drop from a static library).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "oracles/oracle.h"

namespace hrad::oracles {

/// Creates the named oracle from its settings. An unknown name is an
/// InputError listing the valid names. Reads only keys of that oracle; the
/// caller calls params.reportUnused() to reject misspelt settings.
std::unique_ptr<Oracle> createOracle(const std::string& name, const Params& params,
                                     const SourceLocation& where = {});
std::vector<std::string> oracleNames();

}  // namespace hrad::oracles
