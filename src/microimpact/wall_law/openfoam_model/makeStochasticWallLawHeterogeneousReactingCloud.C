/*---------------------------------------------------------------------------*\
    microimpact: registers the patch interaction model stochasticWallLaw for
    OpenFOAM v1912's basicHeterogeneousReactingCloud (one cloud type per file: the registration
    macro declares a typedef of the cloud's kinematicCloudType). Its solvers:
    reactingHeterogenousParcelFoam.
\*---------------------------------------------------------------------------*/

#include "basicHeterogeneousReactingCloud.H"
#include "StochasticWallLaw.H"

makePatchInteractionModelType(StochasticWallLaw, basicHeterogeneousReactingCloud);
