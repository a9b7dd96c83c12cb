// The settings reference: every key some component reads, with its default,
// type, range or allowed values, reader and one-line doc, as core/params
// recorded them while every reader ran on empty Params (HrSettings with each
// oracle, each registered solver, every loader, render, residual,
// references, Slurm). `hrad settings`, docs/settings.md and the README's
// settings table are generated from it, so they cannot disagree with the code.
// Keys of the [reference] table are listed as "reference.KEY", of [slurm] as
// "slurm.KEY".
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/params.h"

namespace hrad::experiments {

/// Every key, sorted by name. `extra` runs more readers (the app's own keys)
/// on the same empty Params.
std::vector<Params::Record> settingsReference(void (*extra)(const Params&) = nullptr);

/// One block per key whose name starts with prefix ("" : all).
std::string settingsText(const std::vector<Params::Record>& records, const std::string& prefix);
/// docs/settings.md: one table per first name component (hr, oracle, cluster...).
std::string settingsMarkdown(const std::vector<Params::Record>& records, const std::string& prefix);
/// The README's table of the settings that matter most (kReadmeKeys).
std::string settingsReadmeTable(const std::vector<Params::Record>& records);

/// What a run used, key -> value (recordResolved values where given): the
/// settings' records and the reference's as "reference.KEY".
nlohmann::json resolvedSettingsJson(const Params& settings, const Params& reference);

/// A record's value as JSON (bool, integer, number or string).
nlohmann::json valueJson(const Params::Value& v);

}  // namespace hrad::experiments
