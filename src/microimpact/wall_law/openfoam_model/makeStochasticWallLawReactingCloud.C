/*---------------------------------------------------------------------------*\
    microimpact: registers the patch interaction model stochasticWallLaw for
    OpenFOAM v1912's basicReactingCloud (one cloud type per file: the registration
    macro declares a typedef of the cloud's kinematicCloudType). Its solvers:
    no solver of Debian's 1912 (a user's reacting solver).
\*---------------------------------------------------------------------------*/

#include "basicReactingCloud.H"
#include "StochasticWallLaw.H"

makePatchInteractionModelType(StochasticWallLaw, basicReactingCloud);
