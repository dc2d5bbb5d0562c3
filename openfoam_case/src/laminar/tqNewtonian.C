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

#include "tqNewtonian.H"
#include "fvm.H"
#include "IOdictionary.H"

// * * * * * * * * * * * * * * * * Constructors  * * * * * * * * * * * * * * //

template<class BasicTurbulenceModel>
Foam::laminarModels::tqNewtonian<BasicTurbulenceModel>::tqNewtonian
(
    const alphaField& alpha,
    const rhoField& rho,
    const volVectorField& U,
    const surfaceScalarField& alphaRhoPhi,
    const surfaceScalarField& phi,
    const transportModel& transport,
    const word& propertiesName
)
:
    Stokes<BasicTurbulenceModel>
    (
        alpha,
        rho,
        U,
        alphaRhoPhi,
        phi,
        transport,
        propertiesName
    )
{
    checkNewtonian();
}


// * * * * * * * * * * * * * Private Member Functions  * * * * * * * * * * * //

template<class BasicTurbulenceModel>
void Foam::laminarModels::tqNewtonian<BasicTurbulenceModel>::checkNewtonian()
const
{
    // The incompressible solvers' transport (singlePhaseTransportModel) is
    // the IOdictionary constant/transportProperties; its viscosity model is
    // the word 'transportModel'.  Any other than Newtonian gives a nu that
    // varies in space, for which the dropped explicit term is not zero.
    const dictionary* dict =
        dynamic_cast<const dictionary*>(&this->transport());

    if (!dict)
    {
        return;
    }

    const word model(dict->lookupOrDefault<word>("transportModel", "Newtonian"));

    if (model != "Newtonian")
    {
        FatalIOErrorInFunction(*dict)
            << "laminarModel " << typeName << " (constant/"
            << this->propertiesName << ") assumes a uniform viscosity, but"
            << " transportModel is '" << model << "' in constant/"
            << "transportProperties." << nl
            << "    Use 'transportModel Newtonian;' or the stock"
            << " 'laminarModel Stokes;'." << nl
            << exit(FatalIOError);
    }
}


// * * * * * * * * * * * * * * * Member Functions  * * * * * * * * * * * * * //

template<class BasicTurbulenceModel>
Foam::tmp<Foam::fvVectorMatrix>
Foam::laminarModels::tqNewtonian<BasicTurbulenceModel>::divDevRhoReff
(
    volVectorField& U
) const
{
    // nuEff() keeps the stock field name: the matrix is the stock
    // laplacian(nuEff,U) of linearViscousStress, its scheme entry unchanged
    return -fvm::laplacian(this->alpha_*this->rho_*this->nuEff(), U);
}


// ************************************************************************* //
