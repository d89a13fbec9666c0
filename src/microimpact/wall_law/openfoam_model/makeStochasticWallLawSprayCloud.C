/*---------------------------------------------------------------------------*\
    microimpact: registers the patch interaction model stochasticWallLaw for
    OpenFOAM v1912's basicSprayCloud (one cloud type per file: the registration
    macro declares a typedef of the cloud's kinematicCloudType). Its solvers:
    sprayFoam, sprayDyMFoam and simpleSprayFoam.
\*---------------------------------------------------------------------------*/

#include "basicSprayCloud.H"
#include "StochasticWallLaw.H"

makePatchInteractionModelType(StochasticWallLaw, basicSprayCloud);
