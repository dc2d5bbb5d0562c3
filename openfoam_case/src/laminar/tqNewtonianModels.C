/*---------------------------------------------------------------------------*\
  =========                 |
  \\      /  F ield         | TunnelQuake: water side, built against
   \\    /   O peration     | OpenFOAM v1912
    \\  /    A nd           |
     \\/     M anipulation  |
-------------------------------------------------------------------------------
License
    GPL-3.0-or-later, like the OpenFOAM libraries it links against.

Description
    Registers laminarModel tqNewtonian for incompressible flow (pimpleFoam)
    in the stock run-time table of laminar models.

    The table (laminarModel<IncompressibleTurbulenceModel<transportModel>>
    ::dictionaryConstructorTable) is defined once, in v1912's
    libincompressibleTurbulenceModels.so (turbulentTransportModels.C, through
    makeBaseTurbulenceModel); turbulentTransportModels.H only names its types
    (makeTurbulenceModelTypes: typedefs) and the makeLaminarModel macro,
    which adds one entry (makeTemplatedTurbulenceModel): nothing of the
    stock tables is redefined here.  libtqFoam.so links that library, so that
    the entry resolves in any solver that loads libtqFoam.so.

\*---------------------------------------------------------------------------*/

#include "turbulentTransportModels.H"
#include "tqNewtonian.H"

// * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * //

makeLaminarModel(tqNewtonian);

// ************************************************************************* //
