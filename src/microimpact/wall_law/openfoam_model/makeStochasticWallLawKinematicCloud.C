/*---------------------------------------------------------------------------*\
    microimpact: registers the patch interaction model stochasticWallLaw for
    OpenFOAM v1912's basicKinematicCloud (one cloud type per file: the registration
    macro declares a typedef of the cloud's kinematicCloudType).
\*---------------------------------------------------------------------------*/

#include "basicKinematicCloud.H"
#include "StochasticWallLaw.H"

makePatchInteractionModelType(StochasticWallLaw, basicKinematicCloud);
