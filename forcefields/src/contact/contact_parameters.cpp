// The contact settings' checks (contact.hpp).
#include "cutsim/base/errors.hpp"
#include "cutsim/base/numbers.hpp"
#include "cutsim/forcefields/contact.hpp"

namespace cutsim::forcefields {

void ContactParameters::validate() const {
  requireFinitePositive("thickness", thickness);
  requireFinitePositive("stiffness", stiffness);
  requireFiniteNonNegative("friction", friction);
  requireFinitePositive("stickVelocity", stickVelocity);
  if (!(displacementFraction > 0 && displacementFraction < 0.5))
    throw InvalidInput(
        "displacementFraction",
        "must be in (0, 0.5) (two primitives each moving less than half their distance "
        "cannot meet), got " +
            describeNumber(displacementFraction));
  if (!(splitAbove >= 0 && splitAbove <= 1))
    throw InvalidInput("splitAbove", "must be in [0, 1], got " + describeNumber(splitAbove));
  if (maxSplits < 0 || maxSplits > 20) throw InvalidInput("maxSplits", "must be in [0, 20]");
  requireFiniteNonNegative("searchSlack", searchSlack);
  if (threads < 0 || threads > 256)
    throw InvalidInput("threads", "must be in [0, 256] (0: as many as the machine has)");
}

}  // namespace cutsim::forcefields
