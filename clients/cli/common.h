// The pieces the coopdyn subcommands share, one job per header.
#pragma once

#include "clients/cli/commands.h"    // the subcommands' option structs
#include "clients/cli/eval_json.h"   // the evaluation as JSON, contact warnings
#include "clients/cli/profile.h"     // --torque and --steer profiles
#include "clients/cli/scene_load.h"  // --scene, --formulation, --state files
#include "clients/cli/text.h"        // JSON strings, shell words
