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
    movingWallVelocityFvPatchVectorField(p, iF),
    wallVelocity_(p.size(), Zero),
    hasWallVelocity_(false)
{}


Foam::tqInterfaceVelocityFvPatchVectorField::
tqInterfaceVelocityFvPatchVectorField
(
    const fvPatch& p,
    const DimensionedField<vector, volMesh>& iF,
    const dictionary& dict
)
:
    movingWallVelocityFvPatchVectorField(p, iF, dict),
    wallVelocity_(p.size(), Zero),
    hasWallVelocity_(false)
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
    movingWallVelocityFvPatchVectorField(ptf, p, iF, mapper),
    wallVelocity_(ptf.wallVelocity_, mapper),
    hasWallVelocity_(ptf.hasWallVelocity_)
{}


Foam::tqInterfaceVelocityFvPatchVectorField::
tqInterfaceVelocityFvPatchVectorField
(
    const tqInterfaceVelocityFvPatchVectorField& ptf
)
:
    movingWallVelocityFvPatchVectorField(ptf),
    wallVelocity_(ptf.wallVelocity_),
    hasWallVelocity_(ptf.hasWallVelocity_)
{}


Foam::tqInterfaceVelocityFvPatchVectorField::
tqInterfaceVelocityFvPatchVectorField
(
    const tqInterfaceVelocityFvPatchVectorField& ptf,
    const DimensionedField<vector, volMesh>& iF
)
:
    movingWallVelocityFvPatchVectorField(ptf, iF),
    wallVelocity_(ptf.wallVelocity_),
    hasWallVelocity_(ptf.hasWallVelocity_)
{}


// * * * * * * * * * * * * * * * Member Functions  * * * * * * * * * * * * * //

void Foam::tqInterfaceVelocityFvPatchVectorField::setWallVelocity
(
    const vectorField& Uw
)
{
    if (Uw.size() != size())
    {
        FatalErrorInFunction
            << "Wall velocity of " << Uw.size() << " faces given for patch "
            << patch().name() << " of " << size() << " faces."
            << exit(FatalError);
    }
    wallVelocity_ = Uw;
    hasWallVelocity_ = true;
}


void Foam::tqInterfaceVelocityFvPatchVectorField::updateCoeffs()
{
    if (updated())
    {
        return;
    }

    if (hasWallVelocity_ && !internalField().mesh().moving())
    {
        // Transpiration: the faces stay, the water takes the wall velocity
        fvPatchVectorField::operator==(wallVelocity_);
    }

    movingWallVelocityFvPatchVectorField::updateCoeffs();
}


void Foam::tqInterfaceVelocityFvPatchVectorField::autoMap
(
    const fvPatchFieldMapper& m
)
{
    movingWallVelocityFvPatchVectorField::autoMap(m);
    wallVelocity_.autoMap(m);
}


void Foam::tqInterfaceVelocityFvPatchVectorField::rmap
(
    const fvPatchVectorField& ptf,
    const labelList& addr
)
{
    movingWallVelocityFvPatchVectorField::rmap(ptf, addr);
    const tqInterfaceVelocityFvPatchVectorField& tiptf =
        refCast<const tqInterfaceVelocityFvPatchVectorField>(ptf);
    wallVelocity_.rmap(tiptf.wallVelocity_, addr);
}


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
