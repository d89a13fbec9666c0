/*---------------------------------------------------------------------------*\
    microimpact: registers the patch interaction model stochasticWallLaw for
    OpenFOAM v1912's basicReactingMultiphaseCloud (one cloud type per file: the registration
    macro declares a typedef of the cloud's kinematicCloudType). Its solvers:
    reactingParcelFoam, simpleReactingParcelFoam and, as coalCloud (the same C++ type), coalChemistryFoam and simpleCoalParcelFoam.
\*---------------------------------------------------------------------------*/

#include "basicReactingMultiphaseCloud.H"
#include "StochasticWallLaw.H"

makePatchInteractionModelType(StochasticWallLaw, basicReactingMultiphaseCloud);
