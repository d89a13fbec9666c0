/*---------------------------------------------------------------------------*\
    microimpact: registers the patch interaction model stochasticWallLaw for
    OpenFOAM v1912's basicKinematicMPPICCloud (one cloud type per file: the registration
    macro declares a typedef of the cloud's kinematicCloudType). Its solvers:
    MPPICFoam, MPPICDyMFoam and MPPICInterFoam.
\*---------------------------------------------------------------------------*/

#include "basicKinematicMPPICCloud.H"
#include "StochasticWallLaw.H"

makePatchInteractionModelType(StochasticWallLaw, basicKinematicMPPICCloud);
