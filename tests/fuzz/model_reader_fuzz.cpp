// Fuzz target for the model-file reader. Every input is parsed twice: as is
// (exercising the header, table and checksum checks) and with its checksums
// recomputed (reaching the section decoders and the model validation). An
// input that parses must survive a write/read round trip unchanged.
#include <cstdint>
#include <cstdlib>
#include <vector>

#include "format_patching.h"
#include "organsim/model/model_file.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  (void)organsim::model::parse_organ_model(data, size, "fuzz");
  std::vector<std::uint8_t> patched(data, data + size);
  organsim::testing::refresh_checksums(patched);
  const organsim::model::ModelReadResult result =
      organsim::model::parse_organ_model(patched.data(), patched.size(), "fuzz");
  if (result) {
    const std::vector<std::uint8_t> again = organsim::model::serialize_organ_model(*result.model);
    const organsim::model::ModelReadResult reread =
        organsim::model::parse_organ_model(again.data(), again.size(), "fuzz");
    if (!reread || !(*reread.model == *result.model)) std::abort();
  }
  return 0;
}
