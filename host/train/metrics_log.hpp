#pragma once
// metrics.jsonl, the run's log: one JSON record per progress report.
#include <string>

#include "nova/train/trainer.hpp"

namespace nova::detail {

// One record of `p`: step, phase, loss, every term, PSNR, learning rate, augmentation, rays/s,
// the occupancy figures (when skipping) and seconds, in this order.
std::string metrics_record(const TrainProgress& p);

// Keeps the records of steps <= `step` (a resumed run continues the same file).
void truncate_metrics(const std::string& path, long step);

}  // namespace nova::detail
