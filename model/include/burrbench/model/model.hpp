#pragma once
// Umbrella header for the burr–bone model kernel (MODEL.md).
#include "burrbench/model/contact.hpp"
#include "burrbench/model/geometry.hpp"
#include "burrbench/model/model_params.hpp"
#include "burrbench/model/replay.hpp"
#include "burrbench/model/sample_estimate_hold.hpp"
#include "burrbench/model/volume.hpp"
