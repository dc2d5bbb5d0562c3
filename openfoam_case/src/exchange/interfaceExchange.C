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

#include "interfaceExchange.H"
#include "addToRunTimeSelectionTable.H"

// * * * * * * * * * * * * * * Static Data Members * * * * * * * * * * * * * //

namespace Foam
{
namespace tq
{
    defineTypeNameAndDebug(interfaceExchange, 0);
    defineRunTimeSelectionTable(interfaceExchange, dictionary);

    defineTypeNameAndDebug(noneExchange, 0);
    addToRunTimeSelectionTable(interfaceExchange, noneExchange, dictionary);
}
}


// * * * * * * * * * * * * * * * * Constructors  * * * * * * * * * * * * * * //

Foam::tq::interfaceExchange::interfaceExchange
(
    const Time& runTime,
    const dictionary& dict
)
:
    time_(runTime),
    dict_(dict),
    readCheckpoint_(false),
    writeCheckpoint_(false)
{}


// * * * * * * * * * * * * * * * * Selectors * * * * * * * * * * * * * * * * //

Foam::autoPtr<Foam::tq::interfaceExchange> Foam::tq::interfaceExchange::New
(
    const Time& runTime,
    const dictionary& dict
)
{
    const word exchangeType(dict.get<word>("type"));

    auto cstrIter = dictionaryConstructorTablePtr_->cfind(exchangeType);

    if (!cstrIter.found())
    {
        FatalIOErrorInFunction(dict)
            << "Unknown interface exchange type '" << exchangeType
            << "' in " << dict.name() << nl
            << "Valid types: " << dictionaryConstructorTablePtr_->sortedToc()
            << nl << "Fix: set 'type' of the exchange dictionary to one of"
            << " these." << exit(FatalIOError);
    }

    return autoPtr<interfaceExchange>(cstrIter()(runTime, dict));
}


Foam::label Foam::tq::interfaceExchange::windowsCompleted() const
{
    return -1;
}


std::string Foam::tq::interfaceExchange::saveState() const
{
    FatalErrorInFunction
        << "The exchange '" << dict_.lookupOrDefault<word>("type", "none")
        << "' writes no restart checkpoints (only the coupler does)."
        << exit(FatalError);
    return std::string();
}


void Foam::tq::interfaceExchange::initializeResumed
(
    const polyPatch&,
    const pointField&,
    const scalarField&,
    const std::string&
)
{
    FatalErrorInFunction
        << "The exchange '" << dict_.lookupOrDefault<word>("type", "none")
        << "' cannot resume from a restart checkpoint (only the coupler"
        << " can)." << exit(FatalError);
}


// ************************************************************************* //
