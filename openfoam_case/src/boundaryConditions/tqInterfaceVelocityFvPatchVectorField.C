/*---------------------------------------------------------------------------*\
  =========                 |
  \\      /  F ield         | TunnelQuake: water side, built against
   \\    /   O peration     | OpenFOAM v1912
    \\  /    A nd           |
     \\/     M anipulation  |
-------------------------------------------------------------------------------
License
    GPL-3.0-or-later, like the OpenFOAM libraries it links against.

\*---------------------------------------------------------------------------*/

#include "tqInterfaceVelocityFvPatchVectorField.H"
#include "addToRunTimeSelectionTable.H"
#include "volFields.H"

// * * * * * * * * * * * * * * * * Constructors  * * * * * * * * * * * * * * //

Foam::tqInterfaceVelocityFvPatchVectorField::
tqInterfaceVelocityFvPatchVectorField
(
    const fvPatch& p,
    const DimensionedField<vector, volMesh>& iF
)
:
    movingWallVelocityFvPatchVectorField(p, iF)
{}


Foam::tqInterfaceVelocityFvPatchVectorField::
tqInterfaceVelocityFvPatchVectorField
(
    const fvPatch& p,
    const DimensionedField<vector, volMesh>& iF,
    const dictionary& dict
)
:
    movingWallVelocityFvPatchVectorField(p, iF, dict)
{}


Foam::tqInterfaceVelocityFvPatchVectorField::
tqInterfaceVelocityFvPatchVectorField
(
    const tqInterfaceVelocityFvPatchVectorField& ptf,
    const fvPatch& p,
    const DimensionedField<vector, volMesh>& iF,
    const fvPatchFieldMapper& mapper
)
:
    movingWallVelocityFvPatchVectorField(ptf, p, iF, mapper)
{}


Foam::tqInterfaceVelocityFvPatchVectorField::
tqInterfaceVelocityFvPatchVectorField
(
    const tqInterfaceVelocityFvPatchVectorField& ptf
)
:
    movingWallVelocityFvPatchVectorField(ptf)
{}


Foam::tqInterfaceVelocityFvPatchVectorField::
tqInterfaceVelocityFvPatchVectorField
(
    const tqInterfaceVelocityFvPatchVectorField& ptf,
    const DimensionedField<vector, volMesh>& iF
)
:
    movingWallVelocityFvPatchVectorField(ptf, iF)
{}


// * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * //

namespace Foam
{
    makePatchTypeField
    (
        fvPatchVectorField,
        tqInterfaceVelocityFvPatchVectorField
    );
}

// ************************************************************************* //
